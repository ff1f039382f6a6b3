"""The takeoff demo's plot says which stack flew, whatever events it marks (a loop variable once
shadowed the label, and the title read 'offb_node -> armed')."""

import matplotlib.axes
from mavros_msgs.msg import State

from offboard_py.tools import demo


def test_the_title_names_the_stack_that_flew(tmp_path, monkeypatch):
    titles = []
    real_set_title = matplotlib.axes.Axes.set_title
    monkeypatch.setattr(matplotlib.axes.Axes, 'set_title',
                        lambda self, text, *a, **k: titles.append(text) or real_set_title(self, text, *a, **k))
    now = [0.0]
    rec = demo.Recorder(0.0, clock=lambda: now[0])
    for t, state in ((1.0, State(connected=True, mode='AUTO.LOITER')),
                     (2.0, State(connected=True, mode='OFFBOARD')),
                     (3.0, State(connected=True, mode='OFFBOARD', armed=True))):
        now[0] = t
        rec.phases.on_state(state)
    assert rec.events(), 'the plot marks the connection, OFFBOARD and the arming'
    label = demo.stack_label(['fcu:=px4_sih', 'bridge:=mavros'])
    demo.plot(rec, str(tmp_path / 'takeoff.png'), label)
    assert (tmp_path / 'takeoff.png').stat().st_size > 0
    assert titles == [demo.plot_title(label)] and 'real PX4' in titles[0] and 'mavros' in titles[0], titles
