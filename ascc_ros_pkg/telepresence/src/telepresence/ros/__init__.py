"""The telepresence nodes (rospy)."""
