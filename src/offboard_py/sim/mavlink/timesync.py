"""PX4's answer to a TIMESYNC request, as src/modules/mavlink/mavlink_timesync.cpp sends it."""

import struct

from offboard_py.dialect import mavlink


class TimesyncAnswer(mavlink.MAVLink_timesync_message):
    """PX4's answer to a TIMESYNC request: tc1 and ts1 and MAVLink's extension fields target_system and
    target_component set to the requester (mavlink_timesync.cpp; recorded: PX4's answers to mavros carry
    1/240, reference/conversations). The dialect's TIMESYNC (pymavlink 2.4.49's) has no extensions, so the
    two bytes are appended to its payload here; a reader without them drops them, as MAVLink 2 allows."""

    def __init__(self, tc1, ts1, target_system, target_component):
        super().__init__(tc1, ts1)
        self.target_system, self.target_component = target_system, target_component

    def pack(self, mav, force_mavlink1=False):
        payload = self.unpacker.pack(self.tc1, self.ts1) + struct.pack('<BB', self.target_system,
                                                                         self.target_component)
        return self._pack(mav, self.crc_extra, payload, force_mavlink1=force_mavlink1)
