"""The vehicle's latest attitude in ROS frames, shared by the plugins that need it.

The bridge updates it on every ATTITUDE_QUATERNION from the target system, before any
plugin's handler for that message runs, so the NED/FRD -> ENU/FLU conversion is done once
per message (mavros keeps the same cache in its UAS object). It publishes nothing itself.
"""

from offboard_py import frames

IDENTITY = (0.0, 0.0, 0.0, 1.0)


class Attitude:
    def __init__(self):
        self.orientation_enu = IDENTITY      # (x, y, z, w): FLU body in the ENU world; identity until known
        self.angular_velocity_flu = (0.0, 0.0, 0.0)   # rad/s about the body's FLU axes
        self.angular_velocity_enu = (0.0, 0.0, 0.0)   # the same rates about the ENU world axes

    def update(self, att):
        """Take an ATTITUDE_QUATERNION (q in w, x, y, z order, NED world, FRD body)."""
        self.orientation_enu = frames.orientation_ned_to_enu(frames.wxyz_to_xyzw(att.q1, att.q2, att.q3, att.q4))
        self.angular_velocity_flu = frames.frd_to_flu(att.rollspeed, att.pitchspeed, att.yawspeed)
        self.angular_velocity_enu = frames.rotate(self.orientation_enu, self.angular_velocity_flu)
