"""Stream statistics used by the benchmark, on hand-made arrival times."""

import pytest

from offboard_py.tools.streamstats import latencies_ms, percentile, stream_quality

MS = 1000000


def test_percentile_nearest_rank():
    values = list(range(1, 101))
    assert percentile(values, 50) == 50
    assert percentile(values, 99) == 99
    assert percentile(values, 100) == 100
    assert percentile([], 50) is None


def test_steady_20hz_stream():
    arrivals = [i * 50 * MS for i in range(201)]
    q = stream_quality(arrivals)
    assert q['rate_hz'] == pytest.approx(20.0)
    assert q['p50_ms'] == q['p99_ms'] == q['max_ms'] == 50.0
    assert q['gaps_over_100ms'] == 0


def test_a_gap_is_seen():
    arrivals = [i * 50 * MS for i in range(100)] + [99 * 50 * MS + 250 * MS]
    q = stream_quality(arrivals)
    assert q['max_ms'] == 250.0 and q['gaps_over_100ms'] == 1
    assert stream_quality([1]) is None


def test_latency_matches_stamp_by_millisecond():
    stamps = [1_000_000_000_000 + i * 50 * MS + 123_456 for i in range(10)]
    arrivals = [(s + 700_000, (s // MS) & 0xFFFFFFFF) for s in stamps]
    lat = latencies_ms(arrivals, stamps)
    assert lat == pytest.approx([0.7] * 10)
    assert latencies_ms([(5, 12345)], stamps) == [], 'no stamp with that millisecond: no value'
