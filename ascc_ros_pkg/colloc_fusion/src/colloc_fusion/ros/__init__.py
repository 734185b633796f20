"""The ROS nodes of colloc_fusion (rospy only here)."""
