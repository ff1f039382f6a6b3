#!/usr/bin/env python3
"""The simulated PX4 (MAVLink over UDP, no ROS needed); the code is in offboard_py.sim."""
import sys
try:
    from offboard_py.sim.main import main
except KeyboardInterrupt:  # stopped while still importing (roslaunch shutting down): no traceback
    sys.exit(0)
sys.exit(main())
