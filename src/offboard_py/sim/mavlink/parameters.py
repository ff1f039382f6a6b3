"""The simulated PX4's parameter manager, as PX4's MavlinkParametersManager (src/modules/mavlink/
mavlink_parameters.cpp): PARAM_REQUEST_LIST (the _HASH_CHECK first, then the table, paced by the loop),
PARAM_REQUEST_READ, PARAM_SET with its PARAM_ERROR, and the PARAM_VALUEs PX4 sends unasked after boot
(send_untransmitted). The table is sim.param_store's."""

import collections
import logging
import struct

from offboard_py import param_codec
from offboard_py.dialect import mavlink
from offboard_py.sim import param_store as sim_params
from offboard_py.sim.mavlink.streams import send_on

log = logging.getLogger('offboard_py.sim')

# PARAM_VALUEs per 10 ms loop step while answering PARAM_REQUEST_LIST: PX4 SITL sent its 889 in 0.80 s
# in the recorded conversations (reference/conversations: the pull from 11.0 to 11.8 s), 11 a step
PARAM_LIST_BATCH = 11
# PX4's parameter manager (mavlink_parameters.cpp send_untransmitted) sends on every link, unasked and in
# index order, each parameter changed since boot and not yet saved, a moment after a change: what its start-up
# script set (sensor ids and priorities, the board offsets, the airframe) at boot 1.00 and 1.03 s in the two
# recordings, and the barometer's offset, set by the sensors module's auto-calibration against GPS altitude
# (SENS_BAR_AUTOCAL), at 5.32 and 5.49 s (reference/px4-sitl-boot-params.json). (boot s, names) in time order
BOOT_PARAM_ANNOUNCEMENTS = (
    (1.0, ('CAL_ACC0_ID', 'CAL_ACC1_ID', 'CAL_ACC2_ID', 'CAL_BARO0_ID', 'CAL_BARO0_PRIO', 'CAL_GYRO0_ID',
           'CAL_GYRO1_ID', 'CAL_GYRO2_ID', 'CAL_MAG0_ID', 'CAL_MAG0_PRIO', 'CAL_MAG1_ID', 'CAL_MAG1_PRIO',
           'SENS_BOARD_X_OFF', 'SENS_DPRES_OFF', 'SYS_AUTOCONFIG', 'SYS_AUTOSTART')),
    (5.4, ('CAL_BARO0_OFF',)))
# The barometer's offset PX4 computed at 5 s (Pa): 6.103515625 and -12.20703125 in the two recordings, multiples
# of the pressure's float resolution, so noise; the table's 0 is the default before the calibration
BARO_OFFSET_PA = 6.103515625


class ParametersManager:
    """The parameters of `px4` (sim.autopilot.SimulatedPx4) on its links."""

    def __init__(self, px4):
        self.px4 = px4
        self.params, self.mav, self.system_id, self.counters = px4.params, px4.mav, px4.system_id, px4.counters
        self.param_lists = {}  # link -> names of a PARAM_REQUEST_LIST answer still to send
        self.boot_announcements = collections.deque(BOOT_PARAM_ANNOUNCEMENTS)  # still to be sent

    def param_value(self, name):
        d = self.params.definition(name)
        return self.mav.param_value_encode(name.encode('ascii'), param_codec.encode(d.type, self.params[name]),
                                           d.type, len(self.params), self.params.index(name))

    def hash_check(self):
        """The list's first PARAM_VALUE, as PX4 sends it: _HASH_CHECK, UINT32, index 65535, not
        counted in param_count (reference/conversations/takeoff-mavros-px4: _HASH_CHECK at t=11.017,
        seq 221, then index 0), so that a ground station with the list cached can stop at once."""
        return self.mav.param_value_encode(
            sim_params.HASH_CHECK_NAME.encode('ascii'),
            struct.unpack('<f', struct.pack('<I', sim_params.HASH_CHECK_VALUE))[0],  # bytewise, as PX4
            mavlink.MAV_PARAM_TYPE_UINT32, len(self.params), sim_params.HASH_CHECK_INDEX)

    def on_request_list(self, msg, link):
        """_HASH_CHECK, then the whole table on the requesting `link`, as PX4, paced by the loop
        (PARAM_LIST_BATCH a step): all at once they overflow a client's socket buffer (a pymavlink
        client on loopback got 785 of 887). 889 take about 0.81 s, as PX4 SITL's 0.80 s. A new
        request while a list is under way on that link starts the table again from index 0 without
        a second _HASH_CHECK, as PX4's MavlinkParametersManager does."""
        if self.px4.for_me(msg):
            restart = link in self.param_lists
            self.param_lists[link] = collections.deque(
                ([] if restart else [sim_params.HASH_CHECK_NAME]) + self.params.names)

    def send_lists(self, out=None):
        """A cycle's batch of each parameter list under way: into out[link] with the cycle's streams
        (so a wake-up that runs several cycles sends each batch between its cycle's streams, as PX4's
        loop does), or at once when `out` is None."""
        for link, pending in list(self.param_lists.items()):
            names = [pending.popleft() for _ in range(min(PARAM_LIST_BATCH, len(pending)))]
            msgs = [self.hash_check() if name == sim_params.HASH_CHECK_NAME else self.param_value(name)
                    for name in names]
            send_on(link, msgs, out)
            if not pending:
                del self.param_lists[link]

    def on_request_read(self, msg, link):
        """By name (param_index -1), or by index (the same name for the same index), answered on `link`; an
        index past the table (888) gets no answer, as on PX4."""
        if not self.px4.for_me(msg):
            return
        if msg.param_index < 0 and msg.param_id == sim_params.HASH_CHECK_NAME:
            link.send(self.hash_check())
            return
        name = msg.param_id if msg.param_index < 0 else (
            self.params.names[msg.param_index] if msg.param_index < len(self.params) else None)
        if name in self.params:
            link.send(self.param_value(name))

    def on_set(self, msg, link):
        """PX4's MAVLink parameter manager: only for its own system id (not 0) and component 1 or 0;
        _HASH_CHECK, an unknown name, a type other than INT32 and REAL32, or not the parameter's own,
        get PARAM_ERROR on the request's `link` and change nothing; otherwise the value is set and
        PARAM_VALUE tells every link the value in force."""
        if msg.target_system != self.system_id or msg.target_component not in (0, 1):
            self.counters['ignored_other_system'] += 1
            return
        name = msg.param_id
        error = None
        if name == sim_params.HASH_CHECK_NAME:
            error = mavlink.MAV_PARAM_ERROR_READ_ONLY
        elif name not in self.params.names:
            error = mavlink.MAV_PARAM_ERROR_DOES_NOT_EXIST
        elif msg.param_type not in (mavlink.MAV_PARAM_TYPE_INT32, mavlink.MAV_PARAM_TYPE_REAL32):
            error = mavlink.MAV_PARAM_ERROR_TYPE_UNSUPPORTED
        elif msg.param_type != self.params.definition(name).type:
            error = mavlink.MAV_PARAM_ERROR_TYPE_MISMATCH
        if error is not None:
            log.warning('PARAM_SET %s (type %d) from system %d refused: PARAM_ERROR %d', name, msg.param_type,
                        msg.get_srcSystem(), error)
            link.send(self.mav.param_error_encode(msg.get_srcSystem(), msg.get_srcComponent(),
                                                  name.encode('ascii', 'replace'), -1, error))
            return
        d = self.params.definition(name)
        try:
            self.params.set(name, param_codec.decode(d.type, msg.param_value))
        except sim_params.ParamRejected as err:
            self.px4.text(mavlink.MAV_SEVERITY_WARNING, str(err))
        self.px4.broadcast(self.param_value(name))  # the value in force, changed or not; PX4 tells every link

    def announce_boot(self, now, out=None):
        """The PARAM_VALUEs PX4 sends on every link unasked after boot (BOOT_PARAM_ANNOUNCEMENTS), when due."""
        while self.boot_announcements and now >= self.boot_announcements[0][0]:
            _, names = self.boot_announcements.popleft()
            if 'CAL_BARO0_OFF' in names:
                self.params.set('CAL_BARO0_OFF', BARO_OFFSET_PA)  # the sensors module's calibration
            self.px4.send_everywhere([self.param_value(name) for name in names], out)
