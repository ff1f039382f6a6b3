#!/usr/bin/env python3
"""Publishes /clock for a run in simulated time; the code is in offboard_py.clock_node."""
import sys
try:
    from offboard_py.clock_node import main
except KeyboardInterrupt:  # stopped while still importing (roslaunch shutting down): no traceback
    sys.exit(0)
sys.exit(main())
