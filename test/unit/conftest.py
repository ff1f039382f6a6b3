"""Under ./run test this tier runs beside the scenarios, in a network namespace of its own
(offboard_py.testing.tiers)."""

from offboard_py.testing.tiers import run_elsewhere


def pytest_collection_modifyitems(config, items):
    run_elsewhere('unit', config, items, 'test-unit.log')
