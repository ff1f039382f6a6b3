"""bench/benchmark.py, offline: what it says of a launch that ended before its vehicles hovered (a
required bridge that could not bind its port ended a 32-vehicle launch, and the benchmark used to wait
out its 308 s start-up bound and then blame every vehicle)."""

import pytest

import bench_scripts

# The lines of the launch log of 2026-11-26 02:40 (a socket held 14550), colour codes and all
DIED = ('\x1b]2;/work/main/.ws/src/offboard_py/launch/multi_uav.launch\x07\n'
        '\x1b[1mprocess[uav10/mavros-22]: started with pid [22545]\x1b[0m\n'
        '[FATAL] [1795660807.156301]: mavros bridge: [Errno 98] cannot bind UDP 127.0.0.1:14550: Address already in use\n'
        '\x1b[31m================================================================================'
        'REQUIRED process [uav10/mavros-22] has died!\n'
        'process has died [pid 22545, exit code 2, cmd mavros_bridge.py __name:=mavros].\x1b[0m\n'
        '[uav10/mavros-22] killing on exit\n')


@pytest.fixture(scope='module')
def benchmark():
    return bench_scripts.load('benchmark')


def write(tmp_path, text):
    path = tmp_path / 'launch-32-1.log'
    path.write_text(text)
    return str(path)


def test_the_fatal_line_is_the_reason(benchmark, tmp_path):
    assert benchmark.launch_failure(write(tmp_path, DIED)) == (
        '[FATAL] [1795660807.156301]: mavros bridge: [Errno 98] cannot bind UDP 127.0.0.1:14550: Address already in use')


def test_without_a_fatal_line_the_required_process_that_died(benchmark, tmp_path):
    text = ''.join(line + '\n' for line in DIED.splitlines() if '[FATAL]' not in line)
    reason = benchmark.launch_failure(write(tmp_path, text))
    assert reason.startswith('=') and 'REQUIRED process [uav10/mavros-22] has died!' in reason
    assert '\x1b' not in reason


def test_otherwise_the_last_line_or_what_is_missing(benchmark, tmp_path):
    assert benchmark.launch_failure(write(tmp_path, 'started\nshutting down\n\n')) == 'shutting down'
    assert benchmark.launch_failure(write(tmp_path, '')) == 'its log is empty'
    assert benchmark.launch_failure(str(tmp_path / 'nowhere.log')).startswith('its log cannot be read')
