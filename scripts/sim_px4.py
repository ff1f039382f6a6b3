#!/usr/bin/env python3
"""The simulated PX4 (MAVLink over UDP, no ROS needed); the code is in offboard_py.sim."""
import sys
from offboard_py.sim.main import main
sys.exit(main())
