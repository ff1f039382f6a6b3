"""A deliberately broken offboard node: it asks for OFFBOARD and arming without streaming
setpoints first (it would only stream once armed). PX4 refuses to arm it, so the takeoff
scenario must fail with it, saying why. Run as test/rostest/broken_offb_node.py by test/meta."""

import rospy
from geometry_msgs.msg import PoseStamped
from mavros_msgs.msg import State
from mavros_msgs.srv import CommandBool, SetMode


def main():
    rospy.init_node('offb_node_py')
    state = [State()]
    rospy.Subscriber('mavros/state', State, lambda m: state.__setitem__(0, m))
    pub = rospy.Publisher('mavros/setpoint_position/local', PoseStamped, queue_size=10)
    set_mode = rospy.ServiceProxy('mavros/set_mode', SetMode)
    arming = rospy.ServiceProxy('mavros/cmd/arming', CommandBool)
    rate = rospy.Rate(1.0)
    try:
        while not rospy.is_shutdown():
            if state[0].connected:
                if state[0].armed:
                    pose = PoseStamped()
                    pose.pose.position.z = 2.0
                    pub.publish(pose)
                else:
                    set_mode(custom_mode='OFFBOARD')
                    arming(value=True)
            rate.sleep()
    except (rospy.ROSInterruptException, rospy.ServiceException):
        pass
    return 0
