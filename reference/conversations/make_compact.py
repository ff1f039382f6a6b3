#!/usr/bin/env python3
"""Make the compact references in this folder from the pcap of a recorded flight.

    python reference/conversations/make_compact.py SHARED/takeoff-mavros-px4.pcap.xz [...]

Writes <stem>.compact.jsonl.xz here: every MAVLink message with t, dir, sys, comp, seq, id, type,
and only the fields offboard_py.conversation reads (HEARTBEAT's, the COMMAND_* ones, the parameter
and mission transactions', TIMESYNC's, EXTENDED_SYS_STATE's landed_state). It reads the pcap, not
the decoded JSONL beside it: there, fields named like the JSONL's own keys took their place (EVENT's
'id', MISSION_CURRENT's 'seq', HEARTBEAT's 'type'). A type the project's dialect does not know is
UNKNOWN_<id> with no fields, as offboard_py.conversation.reading names it.
"""

import json
import lzma
import os
import sys

from offboard_py.conversation import reading

KEEP = {
    'HEARTBEAT': ('type', 'autopilot', 'base_mode', 'custom_mode', 'system_status', 'mavlink_version'),
    'COMMAND_LONG': ('command', 'confirmation', 'param1', 'target_system', 'target_component'),
    'COMMAND_INT': ('command', 'param1', 'target_system', 'target_component'),
    'COMMAND_ACK': ('command', 'result'),
    'SET_MODE': ('base_mode', 'custom_mode'),
    'PARAM_REQUEST_LIST': (), 'PARAM_REQUEST_READ': ('param_id', 'param_index'),
    'PARAM_VALUE': ('param_id', 'param_count', 'param_index'), 'PARAM_SET': ('param_id',),
    'MISSION_REQUEST_LIST': ('mission_type',), 'MISSION_COUNT': ('count', 'mission_type'),
    'MISSION_ACK': ('type', 'mission_type'), 'MISSION_REQUEST_INT': ('seq', 'mission_type'),
    'MISSION_ITEM_INT': ('seq', 'mission_type'), 'MISSION_CLEAR_ALL': ('mission_type',),
    'TIMESYNC': ('tc1', 'ts1'),
    'EXTENDED_SYS_STATE': ('landed_state',),
}


def main(paths):
    here = os.path.dirname(os.path.abspath(__file__))
    for path in paths:
        stem = os.path.basename(path).split('.pcap')[0]
        target = os.path.join(here, stem + '.compact.jsonl.xz')
        messages = reading.read(path)
        with lzma.open(target, 'wt', preset=9 | lzma.PRESET_EXTREME) as out:
            for m in messages:
                out.write(json.dumps(reading.to_record(m, KEEP.get(m.type, ())), separators=(',', ':')) + '\n')
        print('%s: %d messages, %d bytes' % (target, len(messages), os.path.getsize(target)))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
