"""The streams of a MAVLink link of the simulated PX4 and their rates, as PX4's mavlink_main.cpp configures them
per mode and MavlinkStream (mavlink_stream.cpp) schedules them.

`Streams` keeps one interval per message a link sends (`ONBOARD_RATES_HZ`: PX4's "onboard"
mode, as measured on PX4 SITL's offboard-API link; `GCS_RATES_HZ`: SITL's ground-station link,
as measured) and says which are due. MAV_CMD_SET_MESSAGE_INTERVAL
changes an interval for any message the simulator can build, 0 restores the link's default
(which may be off), -1 stops it. HEARTBEAT is fixed at 1 Hz, as on PX4 (setting it answers
FAILED). What each message holds is sim.mavlink.messages'; `send_on` sends a cycle's messages at once or
with the wake-up's other cycles.
"""

from offboard_py.dialect import mavlink

# PX4's MAVLINK_MODE_ONBOARD (mavlink_main.cpp) at the rates PX4 SITL sends on its onboard link
# (reference/px4-sitl-census.json, e.g. 98.5 measured for the 100 Hz ATTITUDE stream;
# GPS_RAW_INT follows the simulated GPS: 8 Hz)
ONBOARD_RATES_HZ = {
    'HEARTBEAT': 1.0,
    'ATTITUDE': 100.0,
    'ATTITUDE_QUATERNION': 50.0,
    'GLOBAL_POSITION_INT': 50.0,
    'HIGHRES_IMU': 50.0,
    'LOCAL_POSITION_NED': 30.0,
    'ODOMETRY': 30.0,
    'TIMESYNC': 10.0,
    'ATTITUDE_TARGET': 10.0,
    'POSITION_TARGET_LOCAL_NED': 10.0,
    # only while armed in an AUTO mode (the navigator's setpoint): 9.9/s from the failsafe's return to the
    # disarm in reference/conversations, none on the ground, in OFFBOARD or after the disarm
    'POSITION_TARGET_GLOBAL_INT': 10.0,
    'ALTITUDE': 10.0,
    'VFR_HUD': 10.0,
    'SERVO_OUTPUT_RAW': 10.0,
    'DISTANCE_SENSOR': 10.0,
    'GPS_RAW_INT': 8.0,
    'SYS_STATUS': 5.0,
    'EXTENDED_SYS_STATE': 5.0,
    'MISSION_CURRENT': 1.0,
    'ESTIMATOR_STATUS': 1.0,
    'SYSTEM_TIME': 1.0,
    'PING': 1.0,
    'SCALED_PRESSURE': 1.0,
    'OPEN_DRONE_ID_LOCATION': 1.0,
    'OPEN_DRONE_ID_SYSTEM': 1.0,
    'LINK_NODE_STATUS': 1.0,
    'HOME_POSITION': 0.5,
    'BATTERY_STATUS': 0.5,
    'VIBRATION': 0.5,
    'CURRENT_MODE': 0.5,
    'TIME_ESTIMATE_TO_TARGET': 0.5,  # configured at 1 Hz, sent on each of the navigator's 2 s updates
    'RC_CHANNELS': 20.0,  # only with an RC link (sim_px4.py --rc): PX4 sends it when input_rc updates
}
# PX4 SITL's GCS link (UDP 18570 -> 14550) as measured (reference/px4-sitl-gcs-census.json, reference/
# px4-sitl-measured.md, "Turn 3 recordings", section 5): PX4's "normal" mode with the seven streams that
# px4-rc.mavlink sets with `mavlink stream -r 50` (49.5 measured), SYS_STATUS and EXTENDED_SYS_STATE at 1 Hz;
# no HIGHRES_IMU, ODOMETRY, TIMESYNC or SYSTEM_TIME. RC_CHANNELS (20 Hz there) only with an RC link (--rc).
GCS_RATES_HZ = {
    'HEARTBEAT': 1.0,
    'ATTITUDE': 50.0,
    'ATTITUDE_QUATERNION': 50.0,
    'ATTITUDE_TARGET': 50.0,
    'GLOBAL_POSITION_INT': 50.0,
    'LOCAL_POSITION_NED': 50.0,
    'POSITION_TARGET_LOCAL_NED': 50.0,
    'SERVO_OUTPUT_RAW': 50.0,
    'GPS_RAW_INT': 5.0,
    'VFR_HUD': 4.0,
    'SYS_STATUS': 1.0,
    'EXTENDED_SYS_STATE': 1.0,
    'ALTITUDE': 1.0,
    'MISSION_CURRENT': 1.0,
    'SCALED_PRESSURE': 1.0,
    'LINK_NODE_STATUS': 1.0,
    'OPEN_DRONE_ID_LOCATION': 1.0,
    'OPEN_DRONE_ID_SYSTEM': 1.0,
    'BATTERY_STATUS': 0.5,
    'CURRENT_MODE': 0.5,
    'DISTANCE_SENSOR': 0.5,
    'ESTIMATOR_STATUS': 0.5,
    'HOME_POSITION': 0.5,
    'TIME_ESTIMATE_TO_TARGET': 0.5,
    'PING': 0.1,
    'VIBRATION': 0.1,
    'RC_CHANNELS': 20.0,
}
FIXED_RATE = frozenset(('HEARTBEAT',))
# Streams PX4 sends only when their data updates, so no interval makes them faster than this (s)
UPDATE_PERIOD_S = {'GPS_RAW_INT': 1.0 / 8.0,              # the simulated GPS: 8 Hz
                   'TIME_ESTIMATE_TO_TARGET': 2.0}        # navigator: rtl_time_estimate every 2 s
# Messages of one link's own state, built for each link that sends them
PER_LINK = frozenset(('LINK_NODE_STATUS',))
# One-shot messages that MAV_CMD_REQUEST_MESSAGE can ask for besides the streams
ON_REQUEST = frozenset(('AUTOPILOT_VERSION', 'PROTOCOL_VERSION', 'GPS_GLOBAL_ORIGIN'))
# Every message the builder makes: what SET_MESSAGE_INTERVAL and REQUEST_MESSAGE accept
STREAMABLE = frozenset(ONBOARD_RATES_HZ) | frozenset(GCS_RATES_HZ)
NAMES_BY_ID = {getattr(mavlink, 'MAVLINK_MSG_ID_' + name): name for name in STREAMABLE | ON_REQUEST}


class Streams:
    """The intervals of one link: `rates_hz` are its defaults."""

    def __init__(self, now_s, rates_hz=ONBOARD_RATES_HZ):
        self.defaults_s = {name: 1.0 / hz for name, hz in rates_hz.items()}
        self.names_by_id = NAMES_BY_ID
        self.interval_s = dict(self.defaults_s)  # as set (what MESSAGE_INTERVAL reports)
        self.period_s = {name: self._period(name, s) for name, s in self.interval_s.items()}  # as sent
        self.next_s = {name: now_s for name in self.interval_s}

    @staticmethod
    def _period(name, interval_s):
        """How often a stream goes out at an interval: no faster than its data updates."""
        return max(interval_s, UPDATE_PERIOD_S.get(name, 0.0))

    def set_interval(self, msg_id, interval_us, now_s):
        """Apply SET_MESSAGE_INTERVAL; True when accepted."""
        name = NAMES_BY_ID.get(int(msg_id))
        if name is None or name in FIXED_RATE or name in ON_REQUEST:
            return False
        if interval_us == 0:
            interval = self.defaults_s.get(name)
        elif interval_us < 0:
            interval = None
        else:
            interval = interval_us * 1e-6
        if interval is None:
            self.interval_s.pop(name, None)
            self.period_s.pop(name, None)
        else:
            self.interval_s[name] = interval
            self.period_s[name] = self._period(name, interval)
            self.next_s[name] = now_s
        return True

    def interval_us(self, msg_id):
        """For MESSAGE_INTERVAL: -1 stopped, 0 unknown/not available, else microseconds."""
        name = NAMES_BY_ID.get(int(msg_id))
        if name is None or name in ON_REQUEST:
            return 0
        interval = self.interval_s.get(name)
        return -1 if interval is None else int(round(interval * 1e6))

    def due(self, now_s):
        """Names of the streams to send now; their next times move on."""
        out = []
        next_s = self.next_s
        for name, interval in self.period_s.items():
            if now_s >= next_s[name]:
                out.append(name)
                # keep the cadence, but never queue a burst after a stall
                next_s[name] = max(next_s[name] + interval, now_s + interval * 0.5)
        return out


def send_on(link, msgs, out=None):
    """msgs into out[link], to go out with the wake-up's cycles, or at once when `out` is None."""
    if out is None:
        link.send_many(msgs)
    else:
        out.setdefault(link, []).extend(msgs)
