#!/usr/bin/env python3
"""The PX4 tutorial's offboard node; the code is in offboard_py.offb_node."""
import sys
from offboard_py.offb_node import main
sys.exit(main())
