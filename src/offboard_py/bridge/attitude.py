"""The vehicle's latest attitude in ROS frames, shared by the plugins that need it.

The bridge updates it on every ATTITUDE_QUATERNION from the target system, before any
plugin's handler for that message runs, and the NED/FRD -> ENU/FLU conversion is done at
most once per message, when something reads it (mavros keeps the same cache in its UAS
object). It publishes nothing itself.
"""

from offboard_py import frames

IDENTITY = (0.0, 0.0, 0.0, 1.0)


class Attitude:
    """orientation_enu (x, y, z, w: FLU body in the ENU world; identity until known),
    angular_velocity_flu (rad/s about the body's FLU axes) and angular_velocity_enu (the same
    rates about the ENU world axes), converted when first read after an update: every
    ATTITUDE_QUATERNION is taken (a new subscriber's first pose or IMU message must carry the
    attitude of now), but most are read by nobody."""

    def __init__(self):
        self._att = None
        self._converted = (IDENTITY, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))

    def update(self, att):
        """Take an ATTITUDE_QUATERNION (q in w, x, y, z order, NED world, FRD body)."""
        self._att = att

    def _values(self):
        att = self._att
        if att is not None:
            orientation = frames.orientation_ned_to_enu(frames.wxyz_to_xyzw(att.q1, att.q2, att.q3, att.q4))
            rates_flu = frames.frd_to_flu(att.rollspeed, att.pitchspeed, att.yawspeed)
            self._converted = (orientation, rates_flu, frames.rotate(orientation, rates_flu))
            self._att = None
        return self._converted

    @property
    def orientation_enu(self):
        return self._values()[0]

    @property
    def angular_velocity_flu(self):
        return self._values()[1]

    @property
    def angular_velocity_enu(self):
        return self._values()[2]
