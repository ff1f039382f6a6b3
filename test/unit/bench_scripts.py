"""bench/'s scripts as modules, for the offline tests of their pure parts. bench/ is not a package and
its scripts import their neighbours (the harness, bench/harness.py), so bench/ is on sys.path while
one loads."""

import importlib.util
import os
import sys

BENCH = os.path.abspath(os.path.join(os.path.dirname(__file__), '..', '..', 'bench'))


def load(script):
    """bench/<script>.py, loaded as module bench_<script>."""
    sys.path.insert(0, BENCH)
    try:
        spec = importlib.util.spec_from_file_location('bench_' + script, os.path.join(BENCH, script + '.py'))
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module
    finally:
        sys.path.remove(BENCH)
