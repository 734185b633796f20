"""The target_follower nodes (rospy)."""
