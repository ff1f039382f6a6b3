"""offboard_py.tools.demo.launch_failure, offline: why a launch ended, as the takeoff demo and the benchmark
say it. A required bridge that could not bind its port ended a 32-vehicle launch (2026-11-26 02:40); the
benchmark waited out its start-up bound and blamed every vehicle, and the reason was then the log's oldest
line among the simulator's exit counters."""

from offboard_py.tools.demo import launch_failure

FATAL = ('[FATAL] [1795660807.156301]: mavros bridge: [Errno 98] cannot bind UDP 127.0.0.1:14550: '
         'Address already in use')
REQUIRED = 'REQUIRED process [uav10/mavros-22] has died!'
# The lines of that launch log, colour codes, title and rules as roslaunch writes them
DIED = ('\x1b]2;/work/main/.ws/src/offboard_py/launch/multi_uav.launch\x07\n'
        '\x1b[1mprocess[uav10/mavros-22]: started with pid [22545]\x1b[0m\n'
        + FATAL + '\n'
        '\x1b[31m================================================================================' + REQUIRED + '\n'
        'process has died [pid 22545, exit code 2, cmd mavros_bridge.py __name:=mavros].\x1b[0m\n'
        '[uav10/mavros-22] killing on exit\n'
        'Shutdown errors:\n'
        + ''.join('[sim_px4 0-31] link: sent %d; vehicle: setpoints_accepted 0\n'
                  '[sim_px4 0-31] GCS link: sent %d\n' % (1800 + k, 1400 + k) for k in range(32)))


def write(tmp_path, text):
    path = tmp_path / 'launch-32-1.log'
    path.write_text(text)
    return str(path)


def test_the_cause_comes_first_however_much_the_simulator_says_after_it(tmp_path):
    said = launch_failure(write(tmp_path, DIED))
    assert said[:2] == [FATAL, REQUIRED]
    assert len(said) == 6 and said[-1] == '[sim_px4 0-31] GCS link: sent 1431'  # then the last words
    assert launch_failure(write(tmp_path, DIED), lines=1) == [FATAL]  # the benchmark's one line


def test_without_a_fatal_line_the_required_process_that_died(tmp_path):
    text = ''.join(line + '\n' for line in DIED.splitlines() if '[FATAL]' not in line)
    said = launch_failure(write(tmp_path, text), lines=1)
    assert said == [REQUIRED]
    assert not any('\x1b' in line for line in launch_failure(write(tmp_path, text)))


def test_a_log_with_no_failure_or_none_at_all(tmp_path):
    assert launch_failure(write(tmp_path, 'started\nshutting down\n')) == []
    assert launch_failure(str(tmp_path / 'nowhere.log')) == []
