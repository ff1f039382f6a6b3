#!/usr/bin/env python3
"""The PX4 tutorial's offboard node; the code is in offboard_py.offb_node."""
import sys
try:
    from offboard_py.offb_node import main
except KeyboardInterrupt:  # stopped while still importing (roslaunch shutting down): no traceback
    sys.exit(0)
sys.exit(main())
