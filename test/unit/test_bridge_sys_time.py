"""The bridge's sys_time plugin: TIMESYNC both ways, mavros's offset filter, FCU-stamped topics.

Offline, on the fake FCU link of bridge_rig. Rules from mavros's sys_time: answer the
FCU's requests with ROS time; observe the offset from answers to ours (round trip under
time/max_rtt_sample); stamp FCU-timed data with FCU time + offset once the filter has
converged (time/convergence_window samples), with ROS time now before that.
"""

import random

import pytest
import rospy

from offboard_py.bridge import diagnostics, local_position, sys_time
from offboard_py.bridge.sys_time import TimesyncFilter
from offboard_py.dialect import mavlink
from bridge_rig import BUILD, Rig

MS = 1000000


def test_filter_converges_to_the_offset_through_jitter():
    """mavros's sys_time hands its UAS the offset after the filter update and before counting the
    sample: the 500th sample converges the filter, the 501st is the first whose offset is used."""
    f = TimesyncFilter(convergence_window=500)
    rng = random.Random(1)
    true_offset = 1795441000 * 10 ** 9 - 50 * 10 ** 9
    for i in range(500):
        assert f.observe(true_offset + rng.randint(-2 * MS, 2 * MS), rng.randint(0, 3 * MS)) is None
        assert f.offset_ns == 0, 'no offset is used before the filter has converged (sample %d)' % (i + 1)
    assert f.converged
    f.observe(true_offset, MS)
    assert abs(f.offset_ns - true_offset) < 1 * MS


def test_filter_skips_slow_or_foreign_round_trips_and_warns_after_six():
    f = TimesyncFilter()
    warnings = [f.observe(5 * MS, 11 * MS) for _ in range(6)]
    assert warnings[:5] == [None] * 5 and 'RTT too high for timesync: 11.00 ms' in warnings[5]
    f.observe(5 * MS, -1)
    assert f.sequence == 0, 'a negative round trip (an answer to someone else) is not a sample'


def test_filter_resets_after_a_clock_jump():
    f = TimesyncFilter(convergence_window=10)
    for _ in range(11):
        f.observe(100 * MS, MS)
    assert f.converged and abs(f.offset_ns - 100 * MS) <= 1
    results = [f.observe(100 * MS + 10 ** 9, MS) for _ in range(6)]
    assert results[:5] == [None] * 5 and 'Time jump detected' in results[5]
    # as mavros: the reset leaves its UAS's offset until the next accepted sample sets it to 0
    assert not f.converged and f.sequence == 0 and abs(f.offset_ns - 100 * MS) <= 1
    f.observe(100 * MS + 10 ** 9, MS)
    assert f.offset_ns == 0, 'the first sample after the reset: not converged, no offset'


class TickingRos:
    """ROS time that the test moves (ns)."""

    def __init__(self, ros, now_ns):
        self.ros, self.now_ns = ros, now_ns

    def __getattr__(self, name):
        return getattr(self.ros, name)

    def now(self):
        return rospy.Time(self.now_ns // 10 ** 9, self.now_ns % 10 ** 9)


def rig(**params):
    r = Rig(sys_time.SysTime, local_position.LocalPosition, **params)
    r.ros_time = TickingRos(r.ros, 1000 * 10 ** 9)
    r.bridge._ros = r.ros_time
    r.bridge.connected = True
    return r


def test_fcu_requests_are_answered_with_ros_time():
    r = rig()
    r.fcu.send(BUILD.timesync_encode(0, 123456789))
    answer = r.fcu.got('TIMESYNC')[0]
    assert (answer.tc1, answer.ts1) == (1000 * 10 ** 9, 123456789)


def test_own_request_goes_with_the_answer_at_the_same_rate():
    """The bridge's 10 Hz request goes right after its answer to the FCU's request when it is due
    within a period, and then not on its timer: PX4 (10 requests a second) gets 10 requests a second
    from the bridge, each stamped with its own send time, and reads both in one wake-up. Each
    message is a datagram of its own, as mavros frames them. Without the FCU's requests the timer
    sends them."""
    r = rig()
    datagrams = []
    receive = r.fcu.receive

    def keep(data):  # the TIMESYNC datagrams: SYSTEM_TIME goes at 1 Hz beside them, each a datagram of its own
        if [m.get_type() for m in mavlink.MAVLink(None).parse_buffer(data)] == ['TIMESYNC']:
            datagrams.append(data)
        return receive(data)
    r.fcu.receive = keep
    start_s = r.clock.now_s

    def timesyncs(data):
        return [(m.tc1, m.ts1) for m in mavlink.MAVLink(None).parse_buffer(data)]
    for i in range(10):  # one second of PX4's requests, 0.1 s apart, and the timer's wake-ups between them
        r.clock.now_s = start_s + 0.1 * i + 0.03
        r.ros_time.now_ns = 1000 * 10 ** 9 + i * 10 ** 8
        r.fcu.send(BUILD.timesync_encode(0, 5 * 10 ** 9 + i))
        assert [timesyncs(d) for d in datagrams[-2:]] == [[(r.ros_time.now_ns, 5 * 10 ** 9 + i)],
                                                          [(0, r.ros_time.now_ns)]], \
            'the answer, then our request stamped now, a datagram each'
        r.bridge.run_periodic(start_s + 0.1 * i + 0.08)
    assert len(datagrams) == 20, 'the timer sent nothing of its own: each request went with an answer'
    assert sum(1 for m in r.fcu.got('TIMESYNC') if m.tc1 == 0) == 10, 'the rate is 10 a second'
    r.fcu.send(BUILD.timesync_encode(0, 7))  # the next request is due within a period: it goes along ...
    r.fcu.send(BUILD.timesync_encode(0, 8))  # ... but not twice in one period: this one is answered alone
    assert [timesyncs(d)[0][0] == 0 for d in datagrams[-3:]] == [False, True, False]
    r.bridge.run_periodic(start_s + 1.5)  # the FCU stopped asking: the timer asks
    assert [m.tc1 for m in mavlink.MAVLink(None).parse_buffer(datagrams[-1])] == [0]


def test_fcu_stamped_pose_uses_the_offset_once_converged():
    r = rig(time__convergence_window=5)
    fcu_boot_ns = 50 * 10 ** 9  # the FCU booted 950 s before ROS time 1000 s
    r.fcu.answers['TIMESYNC'] = lambda m: [BUILD.timesync_encode(fcu_boot_ns, m.ts1)] if m.tc1 == 0 else []

    def pose_stamp(time_boot_ms):
        r.fcu.send(BUILD.local_position_ned_encode(time_boot_ms, 1.0, 2.0, -3.0, 0, 0, 0))
        return r.published('~local_position/pose')[-1].header.stamp

    assert pose_stamp(50100) == rospy.Time(1000), 'not converged: stamped with ROS time now'
    for i in range(5):
        r.bridge.run_periodic(r.clock.now_s + i)  # the 10 Hz request, answered at once
    assert len(r.fcu.got('TIMESYNC')) == 5 and r.plugin.filter.converged
    assert pose_stamp(50100) == rospy.Time(1000), 'converged by the 5th sample; as mavros, used from the 6th'
    r.bridge.run_periodic(r.clock.now_s + 5)
    assert pose_stamp(50100) == rospy.Time(1000, 100 * MS), 'FCU time 50.1 s + offset 950 s'


def test_modes_none_and_passthrough():
    r = rig(time__timesync_mode='NONE')
    r.bridge.run_periodic(r.clock.now_s + 1)
    assert r.fcu.got('TIMESYNC') == [], 'NONE sends no requests'
    r.fcu.send(BUILD.local_position_ned_encode(50100, 0, 0, 0, 0, 0, 0))
    assert r.published('~local_position/pose')[-1].header.stamp == rospy.Time(1000)
    r = rig(time__timesync_mode='PASSTHROUGH')
    r.fcu.send(BUILD.local_position_ned_encode(50100, 0, 0, 0, 0, 0, 0))
    assert r.published('~local_position/pose')[-1].header.stamp == rospy.Time(50, 100 * MS)


def test_time_reference_from_system_time():
    r = rig()
    r.fcu.send(BUILD.system_time_encode(1795441000123456, 5000))
    ref = r.published('~time_reference')[-1]
    assert ref.time_ref == rospy.Time(1795441000, 123456000) and ref.source == 'fcu'
    assert ref.header.stamp == rospy.Time(1000)
    r.fcu.send(BUILD.system_time_encode(0, 6000))
    assert len(r.published('~time_reference')) == 1, 'no Unix time yet: nothing published'


def test_time_sync_status_says_what_mavros_says():
    """mavros's TimeSyncStatus: every answer to our requests counts (a slow one too), the frequency
    over the last ten diagnostics periods, the mean round trip, the FCU's time in the last answer and
    the estimate, in mavros's keys and formats; a time-jump reset starts it again; no such status
    without MAVLINK timesync."""
    none = Rig(sys_time.SysTime, diagnostics.Diagnostics, time__timesync_mode='NONE')
    none.tick(none.clock.now_s + 1.0)
    assert 'mavros: Time Sync' not in {s.name for s in none.published('/diagnostics')[-1].status}

    r = Rig(sys_time.SysTime, diagnostics.Diagnostics, time__convergence_window=20)
    r.ros_time = TickingRos(r.ros, 1000 * 10 ** 9)
    r.bridge._ros = r.ros_time
    r.bridge.connected = True
    fcu = {'ns': 5 * 10 ** 9, 'rtt_ns': 2 * MS}

    def answer(m):
        if m.tc1:
            return []
        r.ros_time.now_ns += fcu['rtt_ns']  # the answer comes back rtt_ns after the request left
        return [BUILD.timesync_encode(fcu['ns'], m.ts1)]

    def status():
        found = {s.name: s for s in r.published('/diagnostics')[-1].status}['mavros: Time Sync']
        return found.level, found.message, [(kv.key, kv.value) for kv in found.values]
    start_s = r.clock.now_s
    r.tick(start_s + 1.0)  # requests go out; the FCU does not answer yet
    assert status()[:2] == (2, 'No events recorded.')
    r.fcu.answers['TIMESYNC'] = answer
    for i in range(1, 101):  # ten seconds of requests at 10 Hz, both clocks moving alike
        fcu['ns'] += 10 ** 8
        r.ros_time.now_ns = 1000 * 10 ** 9 + i * 10 ** 8
        fcu['rtt_ns'] = 12 * MS if i == 50 else 2 * MS  # over max_rtt_sample: counted, not a filter sample
        r.tick(start_s + 1.0 + 0.1 * i)
    level, message, values = status()
    assert (level, message) == (0, 'Normal')
    assert [k for k, _ in values] == ['Timesyncs since startup', 'Frequency (Hz)', 'Last RTT (ms)', 'Mean RTT (ms)',
                                      'Last remote time (s)', 'Estimated time offset (s)']
    values = dict(values)
    count = int(values['Timesyncs since startup'])
    assert count == 100, 'an answer to each request'
    assert r.plugin.filter.sequence == count - 1, 'the slow round trip counted but was not a sample'
    assert float(values['Frequency (Hz)']) == pytest.approx(10.0, abs=0.5)
    assert values['Last RTT (ms)'] == '2.000000'
    assert float(values['Mean RTT (ms)']) == pytest.approx((2.0 * (count - 1) + 12.0) / count, abs=1e-6)
    assert values['Last remote time (s)'] == '%0.9f' % (fcu['ns'] / 1e9)
    assert values['Estimated time offset (s)'] == '%0.9f' % (int(r.plugin.filter.estimate_ns) / 1e9)
    fcu['ns'] += 10 ** 9  # the FCU's clock jumps a second: the sixth answer far from the estimate resets
    for i in range(101, 111):
        fcu['ns'] += 10 ** 8
        r.ros_time.now_ns = 1000 * 10 ** 9 + i * 10 ** 8
        r.tick(start_s + 1.0 + 0.1 * i)
    values = dict(status()[2])
    assert r.plugin.filter.jumps == 1 and int(values['Timesyncs since startup']) < 10, 'counted again from the reset'
    assert values['Mean RTT (ms)'] == '2.000000', 'the slow round trip went with the reset'
