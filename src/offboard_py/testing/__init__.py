"""Test helpers of offboard_py, importable by this package's tests and by other packages'.

ports             instance numbers and UDP ports, from one formula
processes         a child process whose output is collected, with bounded waits on it
mavlink_listener  a raw MAVLink endpoint on a UDP port that records what it receives
mavlink_fuzz      hostile MAVLink datagrams for the fuzz tests
typemask          the SET_POSITION_TARGET type_mask values tests expect, by pymavlink's names
lossy_relay       a lossy, cuttable UDP relay between the bridge and the FCU
broken_offb_node  an offboard node that arms before streaming, which the takeoff scenario must fail
rostest_common    the rostest base class (Vehicle, OffboardTestCase)
Only rostest_common and broken_offb_node import rospy; the others serve the ROS-free tiers.
"""
