"""The phases of a flight to hover as mavros shows them: FCU connected, OFFBOARD, armed, hover.

Fed with mavros/state (on_state) and mavros/local_position/pose (on_pose) messages; no
rospy here, the caller subscribes. Used by the takeoff demo and the benchmark.
"""

import threading
import time

STATE_PHASES = ('connected', 'offboard', 'armed')


class PhaseWatcher:
    """Seconds since t0 at which each phase began.

    `first` maps connected, offboard, armed and hover to the first time each began; `events`
    lists (time, phase) each time a state phase began again (after a loss, a failsafe). Hover
    is the first pose within hover_tolerance_m of hover_z_m (ENU) after the first arming.
    """

    def __init__(self, t0, hover_z_m=2.0, hover_tolerance_m=0.1, clock=time.monotonic):
        self.t0, self.clock = t0, clock
        self.hover_z_m, self.hover_tolerance_m = hover_z_m, hover_tolerance_m
        self.lock = threading.Lock()
        self.first = {}
        self.events = []
        self.mode, self.armed, self.connected = '', False, False
        self.z = None

    def now(self):
        return self.clock() - self.t0

    def _began(self, phase, t):
        self.first.setdefault(phase, t)

    def on_state(self, msg):
        with self.lock:
            t = self.now()
            now_in = {'connected': msg.connected, 'offboard': msg.mode == 'OFFBOARD', 'armed': msg.armed}
            was_in = {'connected': self.connected, 'offboard': self.mode == 'OFFBOARD', 'armed': self.armed}
            for phase in STATE_PHASES:
                if now_in[phase] and not was_in[phase]:
                    self.events.append((t, phase))
                    self._began(phase, t)
            self.mode, self.armed, self.connected = msg.mode, msg.armed, msg.connected

    def on_pose(self, msg):
        with self.lock:
            self.z = msg.pose.position.z
            if 'armed' in self.first and abs(self.z - self.hover_z_m) <= self.hover_tolerance_m:
                self._began('hover', self.now())
