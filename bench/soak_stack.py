"""The soak's stack as processes, and the junk its floods send (bench/soak.py uses them; so does
bench/junk_flood.py): which process of a launch plays which role, their RSS, and hostile
datagrams for the bridge's and the simulator's ports that never say what would end a hover.
"""

import os

from pymavlink.dialects.v10 import common as mavlink1

from offboard_py import px4_modes
from offboard_py.dialect import ARM_DISARM_FORCE_MAGIC
from offboard_py.dialect import mavlink as mavlink2
from offboard_py.testing import mavlink_fuzz
from offboard_py.testing.mavros_typemasks import POSITION_AND_YAW

ROLES = (('sim', b'sim_px4.py'), ('bridge', b'mavros_bridge.py'), ('node', b'offb_node.py'))


def stack_processes(launch_pid):
    """{role: pid} of the node, the bridge and the simulator: roslaunch's children (each node
    runs in a session of its own, so the parent is what ties them to this launch)."""
    found = {}
    for pid in filter(str.isdigit, os.listdir('/proc')):
        try:
            with open('/proc/%s/stat' % pid, 'rb') as f:
                fields = f.read().rsplit(b')', 1)[1].split()
            if int(fields[1]) != launch_pid or fields[0] == b'Z':
                continue
            with open('/proc/%s/cmdline' % pid, 'rb') as f:
                cmd = f.read()
        except (OSError, IndexError, ValueError):
            continue
        role = next((r for r, key in ROLES if key in cmd), None)
        if role:
            found[role] = int(pid)
    return found


def rss_mb(pid):
    try:
        with open('/proc/%d/status' % pid) as f:
            for line in f:
                if line.startswith('VmRSS:'):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return None


# --- junk ------------------------------------------------------------------------------------

def junk_for_bridge(rng, count, target):
    """What the bridge must drop or ignore (test_bridge_fuzz.py's kinds): the vehicle's lies with bad
    CRCs or cut short, the same from other systems, another component's HEARTBEAT, bad enums, NaN."""
    nan = float('nan')
    quad, px4 = mavlink2.MAV_TYPE_QUADROTOR, mavlink2.MAV_AUTOPILOT_PX4
    armed_offboard = mavlink2.MAV_MODE_FLAG_SAFETY_ARMED | mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    vehicle = mavlink2.MAVLink(None, srcSystem=target, srcComponent=1)
    camera = mavlink2.MAVLink(None, srcSystem=target, srcComponent=mavlink2.MAV_COMP_ID_CAMERA)
    other = mavlink2.MAVLink(None, srcSystem=42, srcComponent=1)
    other_v1 = mavlink1.MAVLink(None, srcSystem=43, srcComponent=1)
    lies = [lambda m: m.heartbeat_encode(quad, px4, armed_offboard, px4_modes.encode('AUTO.LAND'),
                                         mavlink2.MAV_STATE_ACTIVE),
            lambda m: m.local_position_ned_encode(1000, 0, 0, -50, 0, 0, 0),
            lambda m: m.extended_sys_state_encode(mavlink2.MAV_VTOL_STATE_UNDEFINED,
                                                  mavlink2.MAV_LANDED_STATE_ON_GROUND)]
    return mavlink_fuzz.hostile_datagrams(
        rng, count, corruptible=[lie(vehicle).pack(vehicle) for lie in lies],
        ignorable=[lie(other).pack(other) for lie in lies]
        + [m.heartbeat_encode(quad, px4, armed_offboard, px4_modes.encode('AUTO.LAND'),
                              mavlink2.MAV_STATE_ACTIVE).pack(m) for m in (camera, other_v1)],
        refused=[other.local_position_ned_encode(1000, nan, nan, nan, nan, nan, nan).pack(other),
                 camera.heartbeat_encode(255, 255, 255, 0xFFFFFFFF, 255).pack(camera)])


def junk_for_sim(rng, count, target):
    """What PX4 must drop or refuse (test/sim/test_fuzz.py's kinds): commands that would end the
    flight with bad CRCs or cut short, the same for other systems, bad modes, NaN and out-of-range
    commands, setpoints and parameters. Nothing here may change the hover."""
    v2 = mavlink2.MAVLink(None, srcSystem=200, srcComponent=1)
    v1 = mavlink1.MAVLink(None, srcSystem=201, srcComponent=1)
    nan, inf = float('nan'), float('inf')
    arm, set_mode = mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, mavlink2.MAV_CMD_DO_SET_MODE
    custom, local_ned = mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mavlink2.MAV_FRAME_LOCAL_NED
    real32 = mavlink2.MAV_PARAM_TYPE_REAL32
    land = px4_modes.encode('AUTO.LAND')
    ending = [v2.command_long_encode(target, 1, arm, 0, 0, ARM_DISARM_FORCE_MAGIC, 0, 0, 0, 0, 0),  # force disarm
              v2.set_mode_encode(target, custom, land),
              v2.command_long_encode(target, 1, mavlink2.MAV_CMD_NAV_LAND, 0, 0, 0, 0, 0, 0, 0, 0),
              v2.param_set_encode(target, 1, b'COM_OF_LOSS_T', 0.1, real32)]
    other_system = [v2.command_long_encode(42, 1, arm, 0, 0, ARM_DISARM_FORCE_MAGIC, 0, 0, 0, 0, 0),
                    v2.set_mode_encode(42, custom, land)]
    other_v1 = [v1.command_long_encode(43, 1, arm, 0, 0, ARM_DISARM_FORCE_MAGIC, 0, 0, 0, 0, 0)]
    refused = [v2.set_mode_encode(target, custom, px4_modes.join(99, 0)),
               v2.command_long_encode(target, 1, set_mode, 0, nan, nan, nan, 0, 0, 0, 0),
               v2.command_long_encode(target, 1, arm, 0, nan, 0, 0, 0, 0, 0, 0),
               v2.param_set_encode(target, 1, b'COM_OF_LOSS_T', nan, real32),
               v2.param_set_encode(target, 1, b'COM_OF_LOSS_T', 1e9, real32),
               v2.set_position_target_local_ned_encode(0, target, 1, 99, POSITION_AND_YAW,
                                                       0, 0, -8, 0, 0, 0, 0, 0, 0, 0, 0),
               v2.set_position_target_local_ned_encode(0, target, 1, local_ned, POSITION_AND_YAW,
                                                       nan, nan, nan, 0, 0, 0, 0, 0, 0, nan, 0),
               v2.set_position_target_local_ned_encode(0, target, 1, local_ned, POSITION_AND_YAW,
                                                       0, 0, inf, 0, 0, 0, 0, 0, 0, 0, 0)]
    return mavlink_fuzz.hostile_datagrams(
        rng, count, corruptible=[m.pack(v2) for m in ending],
        ignorable=[m.pack(v2) for m in other_system] + [m.pack(v1) for m in other_v1],
        refused=[m.pack(v2) for m in refused])
