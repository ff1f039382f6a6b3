"""The vehicle's latest attitude in ROS frames, shared by the plugins that need it.

The bridge gives it every ATTITUDE_QUATERNION frame from the target system, before any plugin's
handler for that message runs; the frame is decoded, and the NED/FRD -> ENU/FLU conversion done,
at most once per message, when something reads it (mavros keeps the same cache in its UAS
object; PX4 sends 50 a second, most read by nobody). It publishes nothing itself.
"""

from offboard_py import frames, wire

IDENTITY = (0.0, 0.0, 0.0, 1.0)


class Attitude:
    """orientation_enu (x, y, z, w: FLU body in the ENU world; identity until known),
    angular_velocity_flu (rad/s about the body's FLU axes) and angular_velocity_enu (the same
    rates about the ENU world axes), converted when first read after an update: every
    ATTITUDE_QUATERNION is taken (a new subscriber's first pose or IMU message must carry the
    attitude of now), but most are read by nobody."""

    def __init__(self):
        self._frame = None
        self._converted = (IDENTITY, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))

    def update(self, frame):
        """Take an ATTITUDE_QUATERNION frame (q in w, x, y, z order, NED world, FRD body), checked by the link."""
        self._frame = frame

    def _values(self):
        frame = self._frame
        if frame is not None:
            att = wire.decode_checked(frame)
            orientation = frames.orientation_ned_to_enu(frames.wxyz_to_xyzw(att.q1, att.q2, att.q3, att.q4))
            rates_flu = frames.frd_to_flu(att.rollspeed, att.pitchspeed, att.yawspeed)
            self._converted = (orientation, rates_flu, frames.rotate(orientation, rates_flu))
            self._frame = None
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
