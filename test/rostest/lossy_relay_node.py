#!/usr/bin/env python3
"""The lossy UDP relay as a roslaunch node (rostest scenarios, launch/soak.launch); the code is in offboard_py.testing.lossy_relay."""
import sys
from offboard_py.testing.lossy_relay import main
sys.exit(main())
