#!/usr/bin/env python3
"""The mavros-compatible bridge (run it as node `mavros`); the code is in offboard_py.bridge."""
import sys
from offboard_py.bridge.node import main
sys.exit(main())
