#!/usr/bin/env python3
"""A node that does not stream before arming (test/meta); the code is in offboard_py.testing.broken_offb_node."""
import sys
from offboard_py.testing.broken_offb_node import main
sys.exit(main())
