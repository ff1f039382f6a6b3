"""Waiting for the ROS master: what is said, when, and the bound (fake clock, no master)."""

import pytest

from offboard_py.master import MasterTimeout, master_timeout_from_argv, wait_for_master

from manual_clock import ManualClock


def test_online_master_says_nothing():
    said = []
    wait_for_master('n', is_online=lambda: True, say=said.append)
    assert said == []


def test_waits_reminds_and_reports_the_master():
    clock, said = ManualClock(), []
    online_at = clock.now_s + 25.0
    wait_for_master('offb_node_py', is_online=lambda: clock.now_s >= online_at, say=said.append, clock=clock,
                    sleep=clock.sleep)
    assert said[0].startswith('offb_node_py: no ROS master at ') and 'is roscore running?' in said[0]
    assert sum('still waiting' in line for line in said) == 2  # at 10 s and 20 s
    assert said[-1].startswith('offb_node_py: ROS master found at ')


def test_bounded_wait_raises_with_the_uri():
    clock = ManualClock()
    with pytest.raises(MasterTimeout) as err:
        wait_for_master('mavros', 3.0, is_online=lambda: False, say=lambda _: None, clock=clock, sleep=clock.sleep)
    assert 'no ROS master at' in str(err.value) and 'after 3 s' in str(err.value)
    assert 3.0 <= clock.now_s - 100.0 <= 3.5


@pytest.mark.parametrize('argv, expected', [([], 0.0), (['_master_timeout:=30'], 30.0), (['x', '_rate:=20'], 0.0)])
def test_timeout_argument(argv, expected):
    assert master_timeout_from_argv(argv) == expected


@pytest.mark.parametrize('text', ['-1', 'soon', 'nan', 'inf'])
def test_bad_timeout_argument_is_named(text):
    with pytest.raises(ValueError) as err:
        master_timeout_from_argv(['_master_timeout:=' + text])
    assert '_master_timeout:=' + text in str(err.value)


def test_a_ctrl_c_during_the_check_is_not_swallowed(monkeypatch):
    """rosgraph.is_master_online() has a bare except: a Ctrl-C landing during its XML-RPC call was
    taken for 'not online' and the wait went on (a fresh-clone CI run killed the node after 10 s)."""
    import rosgraph

    from offboard_py.master import master_online

    def interrupted(_self):
        raise KeyboardInterrupt

    def refused(_self):
        raise ConnectionRefusedError(111, 'Connection refused')

    monkeypatch.setattr(rosgraph.Master, 'getPid', refused)
    assert master_online() is False
    monkeypatch.setattr(rosgraph.Master, 'getPid', interrupted)
    with pytest.raises(KeyboardInterrupt):
        master_online()
