"""Browser console of the telepresence robot (issue 17): protocol, lease, token, map images.

Pure code (no rospy, no tornado); the node is ``web_console.ros.web_console_node``."""
