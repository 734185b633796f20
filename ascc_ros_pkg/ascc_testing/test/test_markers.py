"""ascc_testing.markers: the marker errors rviz would show."""
from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from ascc_testing.markers import marker_array_errors, marker_errors


def _marker(kind, points=0):
    m = Marker()
    m.header.frame_id = "map"
    m.ns, m.type, m.action = "t", kind, Marker.ADD
    m.pose.orientation.w = 1.0
    m.points = [Point(float(i), 0.0, 0.0) for i in range(points)]
    return m


def test_a_drawable_marker_has_no_error():
    assert marker_errors(_marker(Marker.SPHERE)) == []
    assert marker_errors(_marker(Marker.CUBE_LIST, 3)) == []
    assert marker_errors(_marker(Marker.LINE_LIST, 4)) == []


def test_list_without_points_and_odd_lines():
    assert "without points" in marker_errors(_marker(Marker.POINTS))[0]
    assert "line list with 3" in marker_errors(_marker(Marker.LINE_LIST, 3))[0]
    assert "triangle list" in marker_errors(_marker(Marker.TRIANGLE_LIST, 4))[0]
    m = _marker(Marker.SPHERE_LIST, 2)
    m.colors = [ColorRGBA(1.0, 0.0, 0.0, 1.0)]
    assert "1 colours for 2 points" in marker_errors(m)[0]


def test_pose_and_frame():
    m = _marker(Marker.ARROW)
    m.pose.orientation.w = 0.0
    assert "zero quaternion" in marker_errors(m)[0]
    m.pose.position.x = float("nan")
    assert "not finite" in marker_errors(m)[0]
    m = _marker(Marker.ARROW)
    m.header.frame_id = ""
    assert "no frame_id" in marker_errors(m)[0]


def test_deletes_are_not_checked():
    m = _marker(Marker.POINTS)
    m.action = Marker.DELETE
    d = Marker()
    d.action = Marker.DELETEALL
    assert marker_array_errors(MarkerArray(markers=[m, d])) == []
    assert len(marker_array_errors(MarkerArray(markers=[_marker(Marker.POINTS), m]))) == 1
