#!/usr/bin/env python3
"""Says why a launch's stack arguments cannot run, and ends the launch; the code is in offboard_py.stack."""
import sys
from offboard_py.stack import main
sys.exit(main())
