#!/usr/bin/env python3
"""A real PX4 SITL (SIH quadrotor) from $PX4_DIR / --px4-dir; the code is in offboard_py.px4_sih."""
import sys
from offboard_py.px4_sih import main
sys.exit(main())
