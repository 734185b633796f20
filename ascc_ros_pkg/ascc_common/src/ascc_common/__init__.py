"""The stack's shared vocabulary, pure Python (no rospy): planar poses and quaternions
(``ascc_common.pose2d``), occupancy grids and their geometry (``ascc_common.grid``) and
map_server map files (``ascc_common.map_io``)."""
