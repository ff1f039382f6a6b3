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
