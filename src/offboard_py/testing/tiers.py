"""Where a pytest tier of this package runs under `./run test`: beside the rostest scenarios, in a network
namespace of its own, or in catkin's run_tests. `./run test` runs the simulator, offline and processes tiers
beside the scenarios and sets OFFBOARD_PY_TIERS_ELSEWHERE ("sim unit meta") for catkin's run_tests, whose own
copy of each tier then runs nothing and says where it runs. Used by the tiers' conftest.py files."""

import os


def run_elsewhere(tier, config, items, log):
    """Deselect every item of `tier` when ./run test runs it beside the scenarios, saying so once."""
    if tier not in os.environ.get('OFFBOARD_PY_TIERS_ELSEWHERE', '').split() or not items:
        return
    print('\ntest/%s: the %d tests of this tier run beside the scenarios, in their own network namespace '
          '(./run test; results: pytest-%s.xml, log: .ws/%s)' % (tier, len(items), tier, log))
    config.hook.pytest_deselected(items=list(items))
    items[:] = []


def shard_of(value):
    """(k, n) from OFFBOARD_PY_SHARD's "k/n" (1 <= k <= n), None when unset; ValueError naming the value."""
    if not value:
        return None
    part, _, count = value.partition('/')
    try:
        k, n = int(part), int(count)
    except ValueError:
        raise ValueError('OFFBOARD_PY_SHARD must be k/n (e.g. 2/3), got %r' % value) from None
    if not 1 <= k <= n:
        raise ValueError('OFFBOARD_PY_SHARD must be k/n with 1 <= k <= n, got %r' % value)
    return k, n


def run_shard(config, items):
    """Keep the k-th of n shards of a tier (OFFBOARD_PY_SHARD=k/n, as ./run test runs the simulator tier: each
    shard in a network namespace of its own, side by side): every n-th test from the k-th, in the collected order,
    so the long flights spread over the shards. The others are deselected."""
    shard = shard_of(os.environ.get('OFFBOARD_PY_SHARD', ''))
    if shard is None or not items:
        return
    k, n = shard
    kept = [item for index, item in enumerate(items) if index % n == k - 1]
    config.hook.pytest_deselected(items=[item for index, item in enumerate(items) if index % n != k - 1])
    items[:] = kept
