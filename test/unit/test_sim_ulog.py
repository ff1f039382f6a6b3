"""The simulated PX4's ULog files (sim.logger), offline: short flights on a clock that moves only when the test
moves it, each log read back with pyulog, as PX4's own tools (Flight Review, PX4's log tests) read one.

What a log must hold is PX4's (reference/px4-source-logger.json: its logger, its uORB definitions as its build
generated them, its logged topics), and the parameters in its header are PX4 SITL's as recorded
(reference/px4-sitl-params-indexed.tsv); the flight's numbers (the takeoff height) are PX4's parameters.
"""

import logging
import math
import os
import re
import time

import numpy as np
from pyulog import ULog

from offboard_py.dialect import mavlink
from offboard_py.sim.autopilot import SimulatedPx4
from offboard_py.testing.reference import load, px4_param

from manual_clock import ManualClock

STEP_S = 0.01
CLIENT = (255, mavlink.MAV_COMP_ID_MISSIONPLANNER)
NAN = float('nan')
SOURCE = load('px4-source-logger.json')


def figure(group, name):
    return SOURCE[group][name]['value']


def format_fields(text):
    """[(type, array size or 0, name)] of a format 'topic:type name;...', as pyulog reads one."""
    fields = []
    for item in text.split(':', 1)[1].split(';'):
        if item:
            type_text, name = item.split(' ')
            base, _, size = type_text.partition('[')
            fields.append((base, int(size[:-1]) if size else 0, name))
    return fields


class Flight:
    """The simulated PX4 with a log folder, on a manual clock; commands handed to its onboard link."""

    def __init__(self, log_root, *param_overrides):
        self.clock = ManualClock(1000.0)
        self.ap = SimulatedPx4(local_port=0, remote_port=9, gcs=False, ready_delay_s=0.0, clock=self.clock,
                               log_dir=str(log_root), param_overrides=param_overrides)
        self.codec = mavlink.MAVLink(None, srcSystem=CLIENT[0], srcComponent=CLIENT[1])

    def command(self, command, *params):
        params = list(params) + [NAN] * (7 - len(params))
        msg = self.codec.command_long_encode(self.ap.system_id, 1, command, 0, *params)
        self.ap.link.handle_datagram(bytes(msg.pack(self.codec)), ('127.0.0.1', 9))

    def run(self, seconds, until=None):
        for _ in range(int(round(seconds / STEP_S))):
            self.clock.now_s += STEP_S
            self.ap.step(STEP_S)
            if until is not None and until(self.ap.status()):
                return True
        return until is None

    def up_and_down(self):
        """Arm, take off to MIS_TAKEOFF_ALT, land, and wait for the disarm after the landing."""
        self.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0, 0.0)
        self.command(mavlink.MAV_CMD_NAV_TAKEOFF)
        climbed = self.run(20.0, lambda st: st.height >= 0.9 * px4_param('MIS_TAKEOFF_ALT'))
        assert climbed, 'no takeoff: %s' % (self.ap.status(),)
        self.command(mavlink.MAV_CMD_NAV_LAND)
        assert self.run(40.0, lambda st: not st.armed), 'not disarmed after the landing: %s' % (self.ap.status(),)

    def close(self):
        self.ap.close()


def logs(root):
    return sorted(os.path.join(folder, name) for folder, _, names in os.walk(root) for name in names)


def test_a_flight_writes_one_log_that_pyulog_reads_with_px4s_topics_fields_and_parameters(tmp_path):
    root = tmp_path / 'log'
    started_utc = time.time()
    flight = Flight(root)
    try:
        flight.run(2.0)
        flight.up_and_down()
        flight.run(figure('logger', 'stop_after_disarm_s') + 0.5)
    finally:
        flight.close()
    files = logs(root)
    assert len(files) == 1, 'SDLOG_MODE %d: one log from boot to the first disarm, got %s' % (
        figure('logger', 'sdlog_mode_boot_until_disarm'), files)
    pattern = figure('logger', 'log_file').split('/', 1)[1]
    names = {time.strftime(pattern, time.gmtime(t)) for t in range(int(started_utc) - 1, int(time.time()) + 2)}
    assert os.path.relpath(files[0], root) in names, (files[0], pattern)
    with open(files[0], 'rb') as f:
        head = f.read(16)
    assert list(head[:7]) == figure('logger', 'file_magic') and head[7] == figure('logger', 'file_version')

    ulog = ULog(files[0])
    assert not ulog.file_corruption
    assert ulog.msg_info_dict['sys_name'] == figure('logger', 'info')['sys_name']
    for key, value in figure('logger', 'info').items():
        assert ulog.msg_info_dict[key] == value, key
    recorded = load('px4-sitl-autopilot-version.json')['fields']  # the same functions fill AUTOPILOT_VERSION
    assert ulog.msg_info_dict['ver_sw_release'] == recorded['flight_sw_version']  # px4_firmware_version()
    assert ulog.msg_info_dict['sys_os_ver_release'] == recorded['os_sw_version']  # px4_os_version()
    for key in figure('logger', 'info_not_written_on_sitl'):
        assert key not in ulog.msg_info_dict, key
    assert bool(ulog.has_default_parameters) == bool(figure('logger', 'compat_flags0') & 1)

    for name, topic in SOURCE['topics'].items():
        assert ulog.message_formats[name].fields == format_fields(topic['format']), name
    assert ulog.message_formats['event'].fields == format_fields(figure('logger', 'event_topic_format'))
    datasets = {d.name: d for d in ulog.data_list}
    assert set(datasets) == set(SOURCE['topics']), 'topics logged'
    assert all(d.multi_id == 0 for d in datasets.values())
    for name, d in datasets.items():
        steps = np.diff(d.data['timestamp'].astype(np.int64))
        assert np.all(steps >= 0), '%s: timestamps go back' % name
        interval_us = SOURCE['topics'][name]['interval_ms'] * 1000
        if interval_us:
            # uORB's SubscriptionInterval keeps the samples on schedule: never closer than an interval on average
            assert np.mean(steps) >= 0.9 * interval_us, name

    commands = datasets['vehicle_command'].data
    arms = [i for i, c in enumerate(commands['command']) if c == mavlink.MAV_CMD_COMPONENT_ARM_DISARM]
    assert len(arms) == 1 and commands['param1'][arms[0]] == 1.0, commands['command']
    assert commands['source_system'][arms[0]] == CLIENT[0] and commands['from_external'][arms[0]] == 1
    assert math.isnan(commands['param5'][list(commands['command']).index(mavlink.MAV_CMD_NAV_TAKEOFF)])
    armed_us = int(commands['timestamp'][arms[0]])
    acks = datasets['vehicle_command_ack'].data
    assert mavlink.MAV_CMD_COMPONENT_ARM_DISARM in list(acks['command'])

    position = datasets['vehicle_local_position'].data
    ts = position['timestamp'].astype(np.int64)
    assert np.all(np.diff(ts) > 0)
    z_at_arm = position['z'][np.searchsorted(ts, armed_us)]
    assert position['z'][ts > armed_us].min() < z_at_arm - 0.8 * px4_param('MIS_TAKEOFF_ALT'), \
        'z goes up (NED: down is positive) after the arming'
    assert position['xy_valid'].all() and position['z_valid'].all()
    assert position['xy_global'][-1] and not math.isnan(position['ref_lat'][-1])

    status = datasets['vehicle_status'].data
    armed = status['arming_state'] == figure('uorb', 'arming_state_armed')
    assert armed.any() and status['timestamp'][armed].min() >= armed_us
    assert status['arming_state'][-1] == figure('uorb', 'arming_state_disarmed'), 'the log ends after the disarm'
    assert (status['armed_time'][armed] >= armed_us).all()
    landed = datasets['vehicle_land_detected'].data['landed']
    assert landed[0] and not landed.all() and landed[-1], 'landed, in the air, landed'
    assert (datasets['vehicle_attitude'].data['q[0]'] > 0.9).all(), 'near level all along'

    assert len(ulog.initial_parameters) == len(load('px4-sitl-params-indexed.tsv').splitlines())
    for name, value in ulog.initial_parameters.items():
        assert np.float32(value) == np.float32(px4_param(name)), name
    texts = [m.message for m in ulog.logged_messages]
    assert any(t.startswith('Armed by external command') for t in texts), texts
    assert ulog.last_timestamp >= datasets['vehicle_status'].data['timestamp'][-1]


def test_each_arming_after_the_first_disarm_starts_a_log_of_its_own(tmp_path):
    """SDLOG_MODE 1: the boot log ends at the first disarm (1 s later), the next arming starts another file,
    named by the wall clock's UTC at its start."""
    root = tmp_path / 'log'
    flight = Flight(root)
    wall = [1700000000.0]  # for the second log's name: the first was named at boot
    flight.ap.logger.wall_clock = lambda: wall[0]
    try:
        flight.run(1.0)
        flight.up_and_down()
        flight.run(figure('logger', 'stop_after_disarm_s') + 0.5)
        wall[0] += 61.0
        flight.up_and_down()
        flight.run(figure('logger', 'stop_after_disarm_s') + 0.5)
    finally:
        flight.close()
    files = logs(root)
    assert len(files) == 2, files
    pattern = figure('logger', 'log_file').split('/', 1)[1]
    second_file = str(root / time.strftime(pattern, time.gmtime(wall[0])))
    assert second_file in files, files
    first, second = ULog(*[f for f in files if f != second_file]), ULog(second_file)
    assert first.start_timestamp == 0, 'the first log starts at boot'
    boot_status = first.get_dataset('vehicle_status').data
    assert set(boot_status['arming_state']) == {figure('uorb', 'arming_state_armed'),
                                                figure('uorb', 'arming_state_disarmed')}
    second_status = second.get_dataset('vehicle_status').data
    assert second.start_timestamp > first.last_timestamp
    assert second_status['arming_state'][0] == figure('uorb', 'arming_state_armed')


def test_without_a_log_folder_nothing_is_written(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    ap = SimulatedPx4(local_port=0, remote_port=9, gcs=False, clock=ManualClock())
    try:
        assert ap.logger is None
    finally:
        ap.close()
    assert os.listdir(tmp_path) == []


def test_a_log_that_cannot_be_written_is_one_warning_and_the_flight_goes_on(tmp_path, caplog):
    root = tmp_path / 'log'
    flight = Flight(root, 'SDLOG_MODE=0')  # from each arming only: nothing at boot
    flight.ap.logger.wall_clock = lambda: 1700000000.0
    folder = time.strftime('%Y-%m-%d', time.gmtime(1700000000.0))
    (root / folder).write_text('a file where the day\'s folder would go')
    try:
        with caplog.at_level(logging.WARNING, logger='offboard_py.sim'):
            flight.run(1.0)
            flight.up_and_down()
            flight.run(2.0)
    finally:
        flight.close()
    warnings = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert len([w for w in warnings if re.search(re.escape(str(root / folder)), w)]) == 1, warnings
    assert not flight.ap.status().armed, 'the flight went on to its landing'


def test_the_command_line_keeps_each_instance_in_a_log_folder_of_its_own(tmp_path):
    from offboard_py.sim import main
    assert main.default_log_dir({'ROS_HOME': str(tmp_path)}) == str(tmp_path / 'sim_px4' / '{instance}' / 'log')
    assert main.parser().parse_args(['--log-dir', '']).log_dir == ''
    assert main.main(['--vehicles', '2', '--log-dir', str(tmp_path / 'shared')]) == 2, 'two vehicles, one folder'
    assert os.listdir(tmp_path) == []
