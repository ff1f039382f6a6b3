"""How ./run test splits a pytest tier into shards (offboard_py.testing.tiers): every test in exactly one
shard, the long flights spread, a bad OFFBOARD_PY_SHARD refused naming it."""

import pytest

from offboard_py.testing import tiers


class _Hook:
    def __init__(self):
        self.deselected = []

    def pytest_deselected(self, items):
        self.deselected += items


class _Config:
    def __init__(self):
        self.hook = _Hook()


@pytest.mark.parametrize('count', [1, 2, 3, 4])
def test_every_test_runs_in_exactly_one_shard(monkeypatch, count):
    collected = ['test_%02d' % i for i in range(84)]
    seen = []
    for k in range(1, count + 1):
        monkeypatch.setenv('OFFBOARD_PY_SHARD', '%d/%d' % (k, count))
        items, config = list(collected), _Config()
        tiers.run_shard(config, items)
        assert sorted(items + config.hook.deselected) == collected
        assert abs(len(items) - len(collected) / count) < 1
        seen += items
    assert sorted(seen) == collected


def test_consecutive_tests_go_to_different_shards(monkeypatch):
    """A file's long flights sit side by side in the collected order: round robin spreads them."""
    monkeypatch.setenv('OFFBOARD_PY_SHARD', '2/3')
    items = ['long_a', 'long_b', 'long_c', 'short_a', 'short_b', 'short_c']
    tiers.run_shard(_Config(), items)
    assert items == ['long_b', 'short_b']


def test_without_a_shard_every_test_runs(monkeypatch):
    monkeypatch.delenv('OFFBOARD_PY_SHARD', raising=False)
    items = ['a', 'b']
    tiers.run_shard(_Config(), items)
    assert items == ['a', 'b']


@pytest.mark.parametrize('value', ['3', '0/2', '3/2', 'a/b', '1/0', '-1/2'])
def test_a_bad_shard_is_refused_naming_it(value):
    with pytest.raises(ValueError, match='OFFBOARD_PY_SHARD.*%s' % value.replace('/', '/')):
        tiers.shard_of(value)
