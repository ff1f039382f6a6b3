#!/usr/bin/env python3
"""My offboard node: the PX4 tutorial's arming, then a square flown with velocity setpoints, then AUTO.LAND.

As the tutorial (https://docs.px4.io/main/en/ros/mavros_offboard_python.html): wait for the FCU connection,
stream setpoints at 20 Hz, 100 of them before asking for OFFBOARD, then OFFBOARD and arming 5 s apart.
Then, on mavros/setpoint_raw/local with velocity only (position ignored by the type_mask): climb to
~altitude, fly a ~side square at ~speed through its four corners, and ask for AUTO.LAND. The height is held
by feedback on the local position, not by vz 0 alone: PX4's estimated vertical velocity is biased, so a
vz 0 setpoint drifts (offboard_py's reference/px4-sitl-velocity-square.json: 2.5 to 4.3 m on real PX4).
"""
import math

import rospy
from geometry_msgs.msg import PoseStamped
from mavros_msgs.msg import PositionTarget, State
from mavros_msgs.srv import CommandBool, CommandBoolRequest, SetMode, SetModeRequest

# velocity and yaw rate only: position, acceleration and yaw ignored
VELOCITY_ONLY = (PositionTarget.IGNORE_PX | PositionTarget.IGNORE_PY | PositionTarget.IGNORE_PZ
                 | PositionTarget.IGNORE_AFX | PositionTarget.IGNORE_AFY | PositionTarget.IGNORE_AFZ
                 | PositionTarget.IGNORE_YAW)
CORNER_RADIUS_M = 0.3   # a corner is reached within this distance
HEIGHT_GAIN = 1.0       # m/s of climb per m below the altitude
MAX_CLIMB_M_S = 1.0

current_state = State()
current_pose = None


def state_cb(msg):
    global current_state
    current_state = msg


def pose_cb(msg):
    global current_pose
    current_pose = msg


def clamp(value, limit):
    return max(-limit, min(limit, value))


def velocity_setpoint(vx, vy, vz):
    sp = PositionTarget()
    sp.header.stamp = rospy.Time.now()
    sp.coordinate_frame = PositionTarget.FRAME_LOCAL_NED   # mavros takes ENU and sends PX4 NED
    sp.type_mask = VELOCITY_ONLY
    sp.velocity.x, sp.velocity.y, sp.velocity.z = vx, vy, vz
    sp.yaw_rate = 0.0
    return sp


if __name__ == "__main__":
    rospy.init_node("velocity_square_py")
    altitude = rospy.get_param("~altitude", 3.0)
    side = rospy.get_param("~side", 5.0)
    speed = rospy.get_param("~speed", 1.0)

    rospy.Subscriber("mavros/state", State, callback=state_cb)
    rospy.Subscriber("mavros/local_position/pose", PoseStamped, callback=pose_cb)
    setpoint_pub = rospy.Publisher("mavros/setpoint_raw/local", PositionTarget, queue_size=10)
    rospy.wait_for_service("mavros/cmd/arming")
    arming_client = rospy.ServiceProxy("mavros/cmd/arming", CommandBool)
    rospy.wait_for_service("mavros/set_mode")
    set_mode_client = rospy.ServiceProxy("mavros/set_mode", SetMode)

    # the setpoint publishing MUST be faster than 2 Hz
    rate = rospy.Rate(20)

    # wait for the flight controller connection
    while not rospy.is_shutdown() and not current_state.connected:
        rate.sleep()

    # send a few setpoints before starting
    for i in range(100):
        if rospy.is_shutdown():
            break
        setpoint_pub.publish(velocity_setpoint(0.0, 0.0, 0.0))
        rate.sleep()

    offb_set_mode = SetModeRequest(custom_mode="OFFBOARD")
    land_set_mode = SetModeRequest(custom_mode="AUTO.LAND")
    arm_cmd = CommandBoolRequest(value=True)
    last_req = rospy.Time.now()
    phase, corner, start = "arming", 0, None

    while not rospy.is_shutdown():
        if phase == "arming":
            if current_state.mode != "OFFBOARD" and (rospy.Time.now() - last_req) > rospy.Duration(5.0):
                if set_mode_client.call(offb_set_mode).mode_sent:
                    rospy.loginfo("OFFBOARD enabled")
                last_req = rospy.Time.now()
            elif (current_state.mode == "OFFBOARD" and not current_state.armed
                    and (rospy.Time.now() - last_req) > rospy.Duration(5.0)):
                if arming_client.call(arm_cmd).success:
                    rospy.loginfo("Vehicle armed")
                last_req = rospy.Time.now()
            elif current_state.mode == "OFFBOARD" and current_state.armed and current_pose is not None:
                p = current_pose.pose.position
                start, phase = (p.x, p.y), "climb"
                rospy.loginfo("Climbing to %.1f m", altitude)

        # stream always while in OFFBOARD (a hover at the corner while AUTO.LAND is asked for)
        if phase != "land" or current_state.mode == "OFFBOARD":
            vx = vy = vz = 0.0
            if phase != "arming" and current_pose is not None:
                p = current_pose.pose.position
                vz = clamp(HEIGHT_GAIN * (altitude - p.z), MAX_CLIMB_M_S)
                if phase == "climb" and abs(altitude - p.z) < 0.2:
                    phase = "square"
                    rospy.loginfo("Flying the %.1f m square", side)
                if phase == "square":
                    cx, cy = [(side, 0.0), (side, side), (0.0, side), (0.0, 0.0)][corner]
                    dx, dy = start[0] + cx - p.x, start[1] + cy - p.y
                    distance = math.hypot(dx, dy)
                    if distance < CORNER_RADIUS_M:
                        rospy.loginfo("Corner %d reached", corner + 1)
                        corner += 1
                        if corner == 4:
                            phase, last_req = "land", rospy.Time.now() - rospy.Duration(5.0)
                    else:
                        v = min(speed, 0.8 * distance)   # slow down into the corner
                        vx, vy = v * dx / distance, v * dy / distance
            setpoint_pub.publish(velocity_setpoint(vx, vy, vz))

        if phase == "land":
            if current_state.mode != "AUTO.LAND" and (rospy.Time.now() - last_req) > rospy.Duration(5.0):
                if set_mode_client.call(land_set_mode).mode_sent:
                    rospy.loginfo("Landing")
                last_req = rospy.Time.now()
            elif current_state.mode == "AUTO.LAND" and not current_state.armed:
                rospy.loginfo("Landed and disarmed")
                break

        rate.sleep()
