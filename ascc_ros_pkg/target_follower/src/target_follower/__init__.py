"""Camera, target detection and target following of the ASCCbot (thesis 2.4, 5.3).

Pure code (no rospy); the nodes live in ``target_follower.ros``."""
