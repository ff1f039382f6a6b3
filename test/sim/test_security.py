"""Link security of the simulated PX4: MAVLink 2 signing with a key file, and the allow-list.

With a key, PX4 signs what it sends and drops unsigned or badly signed input (MAVLink 1
included: it cannot be signed). The simulator counts what it dropped and says so at exit.
"""

import re
import time

from pymavlink.dialects.v10 import common as mavlink1
from pymavlink.dialects.v20 import development as mavlink2

from offboard_py.dialect import mavlink
from offboard_py.testing.sim_client import ACCEPTED

ARM = mavlink.MAV_CMD_COMPONENT_ARM_DISARM
GCS_COMPONENT = mavlink.MAV_COMP_ID_MISSIONPLANNER


def arm_command(mav, target):
    return mav.command_long_encode(target, 1, ARM, 0, 1, 0, 0, 0, 0, 0, 0)

FAST = ('--ready-delay', '1')
KEY = bytes(range(7, 39))


def no_ack_for(client, send, seconds=1.5):
    start = len(client.acks)
    send()
    client.sleep(seconds)
    return len(client.acks) == start


def exit_counts(sim):
    sim.stop()
    time.sleep(0.3)  # wall seconds: the exited process's last lines reach sim.lines
    text = '\n'.join(sim.lines)
    found = re.search(r'link: (.*); vehicle: (.*)', text)
    assert found, text[-2000:]
    items = (found.group(1) + ', ' + found.group(2)).split(', ')
    return {k: int(v) for k, v in (item.rsplit(' ', 1) for item in items)}


def test_signing_required_drops_unsigned_and_badly_signed(start_sim, tmp_path):
    key_file = tmp_path / 'mavlink-signing-key.bin'
    key_file.write_bytes(KEY)
    sim, client = start_sim('--signing-key', str(key_file), *FAST)
    hb = client.wait_heartbeat()
    assert hb.get_header().incompat_flags & mavlink2.MAVLINK_IFLAG_SIGNED, 'PX4 with a key signs what it sends'
    client.sleep(1.2)

    # unsigned MAVLink 2 (arm, parameter write), MAVLink 1, and a frame signed with another key
    start = len(client.history)
    assert no_ack_for(client, lambda: client.send(arm_command(client.mav, client.target)))
    client.send(client.mav.param_set_encode(client.target, 1, b'MIS_TAKEOFF_ALT', 9.0, mavlink.MAV_PARAM_TYPE_REAL32))
    v1 = mavlink1.MAVLink(None, srcSystem=255, srcComponent=GCS_COMPONENT)
    assert no_ack_for(client, lambda: client.write(arm_command(v1, client.target)
                                                        .pack(v1)))
    forger = mavlink2.MAVLink(None, srcSystem=255, srcComponent=GCS_COMPONENT)
    forger.signing.secret_key, forger.signing.sign_outgoing = bytes(32 * [9]), True
    forger.signing.timestamp = 2 ** 46
    assert no_ack_for(client, lambda: client.write(
        arm_command(forger, client.target).pack(forger)))
    echoes = [m for _, m in client.history[start:] if m.get_type() == 'PARAM_VALUE' and m.param_id == 'MIS_TAKEOFF_ALT']
    assert not client.armed() and not echoes, client.describe()

    # the right key: answered, and the forged far-future timestamp locked nobody out
    client.setup_signing(KEY, sign_outgoing=True)
    assert client.arm() == ACCEPTED
    client.wait_armed(True, 2.0)
    counts = exit_counts(sim)
    assert counts.get('unsigned_rejected') == 3 and counts.get('bad_signature') == 1, counts


def test_setup_signing_provisions_the_key(start_sim):
    sim, client = start_sim(*FAST)
    client.sleep(1.2)
    client.send(client.mav.setup_signing_encode(client.target, 1, list(KEY), 0))
    client.wait_for(lambda: client.latest['HEARTBEAT'].get_header().incompat_flags & mavlink.MAVLINK_IFLAG_SIGNED, 3.0,
                    'a signed HEARTBEAT')
    assert no_ack_for(client, lambda: client.send(arm_command(client.mav, client.target)))
    client.setup_signing(KEY, sign_outgoing=True)
    assert client.arm() == ACCEPTED
    # an all-zero key, signed with the current one, turns signing off again
    client.send(client.mav.setup_signing_encode(client.target, 1, [0] * 32, 0))
    client.disable_signing()
    client.wait_for(lambda: not client.latest['HEARTBEAT'].get_header().incompat_flags & mavlink.MAVLINK_IFLAG_SIGNED,
                    3.0, 'an unsigned HEARTBEAT')
    assert client.arm(False) == ACCEPTED


def test_allow_list_takes_commands_from_listed_systems_only(start_sim):
    sim, client = start_sim('--allow-sysid', '1,42', *FAST)
    client.sleep(1.2)
    assert no_ack_for(client, lambda: client.send(arm_command(client.mav, client.target)))
    for _ in range(10):
        client.send(client.setpoint(0, 0, -2))
        client.sleep(0.02)
    assert not client.armed()
    # reading is open to anyone
    client.read_param('COM_OF_LOSS_T')
    # system 42 is listed (its ACK comes back to the same socket)
    gcs = mavlink2.MAVLink(None, srcSystem=42, srcComponent=GCS_COMPONENT)
    start = len(client.acks)
    client.write(arm_command(gcs, client.target).pack(gcs))
    client.wait_for(lambda: any(a.command == ARM and a.result == ACCEPTED for _, a in client.acks[start:]), 3.0,
                    'arming accepted from system 42')
    client.wait_armed(True, 2.0)
    assert exit_counts(sim)['not_allowed'] == 1 + 10  # the arm command and ten setpoints
    assert any('ignored COMMAND_LONG from system 255' in line for line in sim.lines), sim.lines[-10:]
