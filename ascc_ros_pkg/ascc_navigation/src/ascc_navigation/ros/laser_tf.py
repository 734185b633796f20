"""The laser's mount from TF, for nodes that read scans (rospy, tf2_ros)."""
import rospy

from ascc_navigation.laser import LaserMount


def mount_from_tf(tf_buffer, base_frame, laser_frame, timeout_s=0.05, stamp=None):
    """The LaserMount of ``laser_frame`` in ``base_frame`` from a tf2_ros Buffer, at
    ``stamp`` (a rospy.Time; None: the newest transform), waiting up to ``timeout_s``
    [s]; raises tf2_ros.TransformException if it is unknown, ValueError if the laser is
    tilted."""
    t = tf_buffer.lookup_transform(base_frame, laser_frame,
                                   rospy.Time(0) if stamp is None else stamp,
                                   rospy.Duration(timeout_s))
    tr, q = t.transform.translation, t.transform.rotation
    return LaserMount.from_transform(tr.x, tr.y, q.x, q.y, q.z, q.w)
