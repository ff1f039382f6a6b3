"""offboard_py: the PX4 ROS/MAVROS offboard example, a mavros-compatible bridge and a simulated PX4."""
