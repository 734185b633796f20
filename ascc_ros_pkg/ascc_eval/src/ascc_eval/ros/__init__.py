"""The package's ROS nodes as importable modules, each with ``main()``: the only code
under ``src/`` that imports rospy. The files in ``nodes/`` are shims that call ``main()``."""
