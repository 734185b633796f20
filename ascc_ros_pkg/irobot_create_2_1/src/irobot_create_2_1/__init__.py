"""iRobot Create (first generation) Open Interface: protocol, odometry, virtual Create."""
