"""The ROS nodes of semantic_mapping (the only modules of the package importing rospy)."""
import rospy


def run(node_name, make_node, what):
    """Start a node: ``make_node()`` builds it from its parameters; a bad parameter
    (ValueError) is fatal, logged naming ``what``, with exit status 1."""
    rospy.init_node(node_name)
    try:
        make_node()
    except ValueError as exc:
        rospy.logfatal("%s: bad parameter: %s", what, exc)
        raise SystemExit(1) from exc
    rospy.spin()
