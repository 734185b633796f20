"""What rviz would show as an error of a Marker or MarkerArray display, for tests.

``marker_errors(marker)`` lists, as text, the problems for which rviz marks a display red
instead of drawing the marker: a list type (points, lines, cubes, spheres, triangles)
without points, a line list with an odd number of points, a triangle list whose points
are not a multiple of three, a per-point colour list of another length than the points, a
pose that is not finite, a quaternion of zero length, no frame. Only markers that are
added (``action`` ADD) are checked; DELETE and DELETEALL carry no geometry.
"""
import math

from visualization_msgs.msg import Marker

LIST_TYPES = (Marker.LINE_STRIP, Marker.LINE_LIST, Marker.CUBE_LIST, Marker.SPHERE_LIST,
              Marker.POINTS, Marker.TRIANGLE_LIST)


def marker_errors(m):
    """The rviz errors of Marker ``m`` (empty when it would be drawn)."""
    if m.action != Marker.ADD:
        return []
    out = []
    what = "marker %s/%d" % (m.ns, m.id)
    if not m.header.frame_id:
        out.append("%s: no frame_id" % what)
    p, q = m.pose.position, m.pose.orientation
    if not all(math.isfinite(v) for v in (p.x, p.y, p.z, q.x, q.y, q.z, q.w)):
        out.append("%s: pose not finite" % what)
    elif q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w < 1e-12:
        out.append("%s: zero quaternion" % what)
    if m.type in LIST_TYPES:
        n = len(m.points)
        if n == 0:
            out.append("%s: list type %d without points" % (what, m.type))
        elif m.type == Marker.LINE_LIST and n % 2:
            out.append("%s: line list with %d points" % (what, n))
        elif m.type == Marker.TRIANGLE_LIST and n % 3:
            out.append("%s: triangle list with %d points" % (what, n))
        if m.colors and len(m.colors) != n:
            out.append("%s: %d colours for %d points" % (what, len(m.colors), n))
    return out


def marker_array_errors(msg):
    """The rviz errors of every marker of MarkerArray ``msg``."""
    return [e for m in msg.markers for e in marker_errors(m)]
