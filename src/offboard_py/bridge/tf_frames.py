"""mavros's frames: /tf and /tf_static as the running mavros offers them, whatever the plugins do.

mavros's UAS holds a tf2 broadcaster (so /tf is advertised by every mavros) and at start sends
three static transforms on /tf_static (latched), which tell ROS tools how PX4's frames sit in
ROS's: map -> map_ned and odom -> odom_ned (ENU to NED) and base_link -> base_link_frd (FLU to
FRD), the same rotations offboard_py.frames uses (reference/mavros-1.21-px4-api.txt lists both
topics with one publisher each). What goes on /tf itself is local_position's (its tf/send).
"""

from geometry_msgs.msg import TransformStamped
from tf2_msgs.msg import TFMessage

from offboard_py import frames

STATIC = (('map', 'map_ned', frames.Q_ENU_NED), ('odom', 'odom_ned', frames.Q_ENU_NED),
          ('base_link', 'base_link_frd', frames.Q_FLU_FRD))


def static_transforms(stamp):
    """The TFMessage mavros latches on /tf_static."""
    transforms = []
    for parent, child, q in STATIC:
        t = TransformStamped()
        t.header.stamp, t.header.frame_id, t.child_frame_id = stamp, parent, child
        t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z, t.transform.rotation.w = q
        transforms.append(t)
    return TFMessage(transforms=transforms)


class TfFrames:
    def __init__(self, bridge):
        self.tf_pub = bridge.publisher('/tf', TFMessage, queue_size=100)
        self.static_pub = bridge.publisher('/tf_static', TFMessage, queue_size=1, latch=True)
        self.static_pub.publish(static_transforms(bridge.now()))
