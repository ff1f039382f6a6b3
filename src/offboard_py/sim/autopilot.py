"""The simulated PX4's MAVLink side wired together, as PX4's mavlink module (src/modules/mavlink) runs an
instance per link: the links, the receiver, the parameter and mission managers, the command sender, the
STATUSTEXT queue and the streams (sim/mavlink/), and the loop's cycle (step).

Two UDP links, as PX4 SITL has: the offboard-API link (local 14580+N, sending to 14540+N)
with PX4's onboard stream set, and the ground-station link (local 18570+N, sending to 14550)
with PX4's normal (GCS) stream set; each sends to whoever talks to it once someone does.
Both links take the same requests through one receiver (sim.mavlink.receiver), and a reply goes
back on the link its request came from. The flight stack
(sim.flight) steps at `rate_hz` of its clock (real time, or simulated time at `speed` times
real time: offboard_py.simtime); the streams due at each step are built for that step (each
message once, whatever the number of links), and those of the `steps_per_wakeup` steps of one
wake-up go out together (run()), each message in a datagram of its own as PX4 frames them; what
the flight stack says (mode changes, mission progress) goes out on both links at once, its texts
(STATUSTEXT) only on a link where a ground station's HEARTBEAT was heard, as PX4.
"""

import logging

from offboard_py import sitl_ports
from offboard_py.mavlink_link import MavlinkLink
from offboard_py.simtime import SimClock
from offboard_py.signing import SigningKeyError, read_signing_key
from offboard_py.sim import events as ev
from offboard_py.sim import loop
from offboard_py.sim import param_store as sim_params
from offboard_py.sim.commander import READY_S
from offboard_py.sim.flight import Flight
from offboard_py.sim.geo import GeoOrigin
from offboard_py.sim.logger import Logger
from offboard_py.sim.mavlink import mission_manager, streams as sim_streams
from offboard_py.sim.mavlink.command_sender import CommandSender
from offboard_py.sim.mavlink.link_stats import LinkCounters
from offboard_py.sim.mavlink.messages import TelemetryBuilder
from offboard_py.sim.mavlink.parameters import ParametersManager
from offboard_py.sim.mavlink.receiver import Receiver
from offboard_py.sim.mavlink.statustext import StatustextQueue
from offboard_py.sim.mavlink.streams import send_on
from offboard_py.dialect import mavlink

log = logging.getLogger('offboard_py.sim')

DEFAULT_HOME = (47.397742, 8.545594, 488.0)  # PX4 SITL's default home (Zurich)
# GPS_GLOBAL_ORIGIN went out once, 1.0 s after the link's first message, in both real-PX4 recordings
# (reference/conversations/takeoff-mavros-px4 t=1.005, takeoff-bridge-px4 t=1.013: boot 1.44 and 1.33 s,
# PX4's links starting 0.3-0.45 s after its boot); this simulator's links start at its boot
ORIGIN_FIRST_SENT_S = 1.0


class SimulatedPx4:
    def __init__(self, instance=0, home=DEFAULT_HOME, bind_host='127.0.0.1', local_port=None, remote_port=None,
                 param_overrides=(), ready_delay_s=READY_S, rc=False, rate_hz=100.0, steps_per_wakeup=2, clock=None,
                 signing_key_file=None, allowed_systems=(), gcs=True, gcs_port=None, gcs_remote_port=None,
                 pack_datagrams=False, log_dir=None):
        # Every timer, rate and time_boot_ms runs on this clock: speed x real time
        self.clock = SimClock(1.0) if clock is None else clock
        clock = self.clock
        self.system_id = sitl_ports.system_id(instance)
        self.rate_hz = rate_hz
        self.steps_per_wakeup = steps_per_wakeup
        now = clock()
        self.boot_s = now
        self.params = sim_params.ParamStore(system_id=self.system_id)
        for text in param_overrides:
            self.params.parse_override(text)
        self.origin = GeoOrigin(*home)
        self.flight = Flight(self.params, self.origin, self.t(now), ready_delay_s=ready_delay_s, rc=rc)
        local_port = sitl_ports.fcu_port(instance) if local_port is None else local_port
        remote_port = sitl_ports.bridge_port(instance) if remote_port is None else remote_port
        # Both links keep the first sender they hear from, as PX4's UDP links do (mavlink_link._lock_partner)
        self.link = MavlinkLink((bind_host, local_port), (bind_host, remote_port), self.system_id, 1,
                                name='onboard', lock_remote=True, clock=clock, pack_datagrams=pack_datagrams)
        # what the simulator sends: built by pymavlink's codec, packed and numbered by the link
        self.mav = self.link.mav
        self.links = [self.link]
        self.gcs_link = None
        if gcs:
            gcs_port = sitl_ports.gcs_port(instance) if gcs_port is None else gcs_port
            gcs_remote_port = sitl_ports.GCS_REMOTE_PORT if gcs_remote_port is None else gcs_remote_port
            try:
                self.gcs_link = MavlinkLink((bind_host, gcs_port), (bind_host, gcs_remote_port), self.system_id, 1,
                                            name='GCS', lock_remote=True, clock=clock,
                                            pack_datagrams=pack_datagrams)
            except OSError:
                self.link.close()
                raise
            self.links.append(self.gcs_link)
        self.reached_repeats = {link: mission_manager.ReachedRepeats() for link in self.links}
        self.streams = {self.link: sim_streams.Streams(self.t(now), sim_streams.ONBOARD_RATES_HZ)}
        if self.gcs_link:
            self.streams[self.gcs_link] = sim_streams.Streams(self.t(now), sim_streams.GCS_RATES_HZ)
        for streams in self.streams.values():  # HOME_POSITION as soon as home is set, then at its rate
            streams.next_s['HOME_POSITION'] = self.t(now) + self.flight.home_first_s
        self.telemetry = TelemetryBuilder(self.mav, self.origin, self.params)
        self.link_counters = {link: LinkCounters(link.stats, self.t(now)) for link in self.links}
        for link, counters in self.link_counters.items():
            link.on_frames(counters.on_frame)  # LINK_NODE_STATUS.messages_lost, counted as PX4 counts it
        self.command_sender = CommandSender(clock, self.mav, self.system_id, self.links)
        self.texts = StatustextQueue(self.links, self.telemetry.mav)
        self.origin_sent = False  # GPS_GLOBAL_ORIGIN's one message on every link (ORIGIN_FIRST_SENT_S)
        # the instrumentation seam (sim.instrumentation, for ./run bench): f(msg, link) for every accepted
        # setpoint; empty unless the benchmark measures (PX4 has nothing of the kind)
        self.setpoint_probes = []
        self.counters = {'setpoints_accepted': 0, 'setpoints_rejected': 0, 'ignored_other_system': 0,
                         'not_allowed': 0}
        # Signing as PX4 does it with a key on its SD card: outgoing signed, incoming must be.
        self.signing_key_file = signing_key_file
        if signing_key_file:
            try:
                key, timestamp = read_signing_key(signing_key_file)
            except SigningKeyError:
                self.close_links()
                raise
            for link in self.links:
                link.enable_signing(key, timestamp, required=True)
        self.allowed_systems = frozenset(allowed_systems)  # empty: commands from anyone
        self.mission_manager = mission_manager.MissionManager(
            self.mav, self.system_id, lambda text: self.text(mavlink.MAV_SEVERITY_CRITICAL, text),
            self._on_mission_changed)
        self.parameters = ParametersManager(self)
        self.log_root = log_dir or None  # PX4's log folder (sim.logger, sim.mavlink.log_handler); None: no logs
        self.logger = None
        self.receiver = Receiver(self)
        if self.log_root:
            self.logger = Logger(self.log_root, self.params, self.flight, self.origin, self.system_id, self.t(now),
                                 self.text)
            self.logger.boot(self.t(now))
        self.running = False

    def t(self, now=None):
        """Seconds since boot: the time base of every pure module."""
        return (self.clock() if now is None else now) - self.boot_s

    def status(self):
        return self.flight.status(self.t())

    # -- what the parts share: the links, the ids, the texts ----------------------------------

    def broadcast(self, msg):
        for link in self.links:
            link.send(msg)

    def send_everywhere(self, msgs, out=None):
        """What PX4 sends on every link of its own accord, with the cycle (streams.send_on)."""
        for link in self.links:
            send_on(link, msgs, out)

    def for_me(self, msg):
        """PX4 takes messages for its system id or for all (0), on component 1 or all (0)."""
        if msg.target_system in (0, self.system_id) and getattr(msg, 'target_component', 0) in (0, 1):
            return True
        self.counters['ignored_other_system'] += 1
        return False

    def text(self, severity, text):
        """A text for every link's STATUSTEXT queue (sim.mavlink.statustext), and for the log."""
        self.texts.add(severity, text, self.t())
        if self.logger is not None:
            self.logger.on_text(severity, text, self.t())

    def _on_mission_changed(self, mission_type):
        if mission_type == mission_manager.MISSION_TYPE_MISSION:
            for repeats in self.reached_repeats.values():
                repeats.forget()
            self.flight.load_mission(self.mission_manager.mission())
            self.say_events()
        elif mission_type == mavlink.MAV_MISSION_TYPE_FENCE:
            self.flight.load_fence(self.mission_manager.items[mission_type])

    # -- the cycle -----------------------------------------------------------------------------

    def say_events(self):
        """What the flight stack said, on the link."""
        events = self.flight.take_events()
        if not events:
            return
        if self.logger is not None:
            self.logger.on_events(events)
        now = self.t()
        status = self.flight.status(now)
        for event in events:
            if isinstance(event, ev.ModeChanged):
                # logged only: PX4 says a mode change in its next 1 Hz HEARTBEAT and 0.5 Hz CURRENT_MODE, not
                # at once (the recorded conversations: both strictly periodic through every change)
                log.info('mode %s%s, %s', status.nav_mode, ' (failsafe)' if status.failsafe else '',
                         'armed' if status.armed else 'disarmed')
            elif isinstance(event, ev.StatusText) and event.on_link:
                self.text(event.severity, event.text)
            elif isinstance(event, ev.StatusText):
                log.info('%s', event.text)  # PX4 says it as an event only (sim.commander._event)
            elif isinstance(event, ev.MissionCurrent):
                self.broadcast(self.telemetry.build('MISSION_CURRENT', status, now))
            elif isinstance(event, ev.ItemReached):
                self.broadcast(self.mav.mission_item_reached_encode(event.seq))
                for repeats in self.reached_repeats.values():
                    repeats.reached(event.seq)
            elif isinstance(event, ev.VehicleCommand):
                self.command_sender.send_vehicle_command(event)

    def step(self, dt, slot_s=None, out=None):
        """One cycle of the loop at `slot_s` (the cycle's time on the loop's schedule, seconds
        since boot; default: now): the flight stack's timers, the streams due then and their
        values are that time's, also when one wake-up runs several cycles. The streams and the
        cycle's batch of a parameter list are appended to out[link] to go out with the rest of the
        wake-up's cycles, or sent at once when `out` is None. What the flight stack says (modes,
        mission progress) goes out at once; its texts with the cycle, where a ground station listens."""
        self.command_sender.send_deferred()
        now = self.t() if slot_s is None else slot_s
        self.flight.step(now, dt)
        self.mission_manager.tick(now)
        self.say_events()
        if self.parameters.param_lists:
            self.parameters.send_lists(out)
        for log_handler in self.receiver.log_handlers.values():
            log_handler.send(now, out)
        self.texts.send(now, out)
        if not self.origin_sent and now >= ORIGIN_FIRST_SENT_S:
            self.origin_sent = True
            self.send_everywhere([self.telemetry.build('GPS_GLOBAL_ORIGIN', None, now)], out)
        self.parameters.announce_boot(now, out)
        status, built = None, {}
        for link, streams in self.streams.items():
            due = streams.due(now)
            if not due:
                continue
            msgs = [] if out is None else out.setdefault(link, [])
            for name in due:
                if name in sim_streams.PER_LINK:
                    msgs.append(self.receiver.build(name, link, now))
                    continue
                if name not in built:  # one message per step for all the links that want it
                    if status is None:
                        status = self.flight.status(now)
                    built[name] = self.telemetry.build(name, status, now)
                if built[name] is not None:
                    msgs.append(built[name])
                if name == 'MISSION_CURRENT':
                    seq = self.reached_repeats[link].due(len(self.flight.navigator.mission.items))
                    if seq is not None:
                        msgs.append(self.mav.mission_item_reached_encode(seq))
            if out is None and msgs:
                link.send_many(msgs)
        if self.logger is not None:
            self.logger.step(now, status)

    # -- the loop --------------------------------------------------------------------------

    def run(self, duration_s=None):
        """Run on the clock until stop() (or for duration_s of its seconds): the loop of
        offboard_py.sim.loop with this vehicle alone."""
        loop.run_together([self], duration_s)

    def stop(self):
        self.running = False

    def close(self):
        def counts(counter):
            return ', '.join('%s %d' % kv for kv in sorted(counter.items()))
        log.info('link: %s; vehicle: %s', counts(self.link.stats), counts(self.counters))
        if self.gcs_link:
            log.info('GCS link: %s', counts(self.gcs_link.stats))
        if self.logger is not None:
            self.logger.close()
        for log_handler in self.receiver.log_handlers.values():
            log_handler.close()
        self.close_links()

    def close_links(self):
        for link in self.links:
            link.close()
