#!/usr/bin/env python3
"""The takeoff demo (launch, live status, plot); the code is in offboard_py.tools.demo."""
import sys
from offboard_py.tools.demo import main
sys.exit(main())
