"""Statistics of a setpoint stream as the FCU saw it: rate, inter-arrival, gaps, latency.

Pure functions over arrival times (ns) and ROS header stamps (ns); used by the benchmark.
"""

import math


def percentile(values, q):
    """The q-th percentile (0..100) by nearest rank; None for no values."""
    if not values:
        return None
    ordered = sorted(values)
    rank = math.ceil(q / 100.0 * len(ordered))  # nearest rank, 1-based
    return ordered[max(0, min(len(ordered), rank) - 1)]


def stream_quality(arrivals_ns, gap_ms=100.0):
    """Mean rate (Hz), inter-arrival p50/p99/max (ms) and the number of gaps over gap_ms."""
    if len(arrivals_ns) < 2:
        return None
    gaps = [(b - a) / 1e6 for a, b in zip(arrivals_ns, arrivals_ns[1:])]
    span_s = (arrivals_ns[-1] - arrivals_ns[0]) / 1e9
    return {'count': len(arrivals_ns), 'rate_hz': (len(arrivals_ns) - 1) / span_s,
            'p50_ms': percentile(gaps, 50), 'p99_ms': percentile(gaps, 99), 'max_ms': max(gaps),
            'gaps_over_%dms' % gap_ms: sum(1 for g in gaps if g > gap_ms)}


def latencies_ms(arrivals, stamps_ns):
    """Publication-to-FCU latency (ms) of each arrival.

    arrivals: (arrival ns, time_boot_ms) as the FCU logged them; time_boot_ms is the ROS
    stamp in ms modulo 2**32, as mavros fills it. stamps_ns: header stamps seen in ROS.
    Each arrival is matched to the latest stamp not after it with the same ms value.
    """
    by_ms = {}
    for stamp in stamps_ns:
        by_ms.setdefault((stamp // 1000000) & 0xFFFFFFFF, []).append(stamp)
    out = []
    for arrival, boot_ms in arrivals:
        candidates = [s for s in by_ms.get(boot_ms, ()) if s <= arrival]
        if candidates:
            out.append((arrival - max(candidates)) / 1e6)
    return out
