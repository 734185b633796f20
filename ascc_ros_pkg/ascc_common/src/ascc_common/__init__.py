"""The stack's shared vocabulary, pure Python (no rospy): planar poses and quaternions
(``ascc_common.pose2d``)."""
