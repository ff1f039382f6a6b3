#!/usr/bin/env python3
"""The mavros-compatible bridge (run it as node `mavros`); the code is in offboard_py.bridge."""
import sys
try:
    from offboard_py.bridge.node import main
except KeyboardInterrupt:  # stopped while still importing (roslaunch shutting down): no traceback
    sys.exit(0)
sys.exit(main())
