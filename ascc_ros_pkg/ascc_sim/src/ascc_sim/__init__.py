"""ascc_sim: a headless 2D simulator of the ASCCbot (iRobot Create + Hokuyo URG-04LX).

Pure code, no rospy: world files (:mod:`ascc_sim.world`), the grid and collision tests
(:mod:`ascc_sim.grid`), the laser model (:mod:`ascc_sim.laser`), scripted people
(:mod:`ascc_sim.people`), robot kinematics and the stepping core (:mod:`ascc_sim.sim`) and
the world generator used by ``scripts/make_worlds.py`` (:mod:`ascc_sim.worldgen`).
The ROS wiring lives in :mod:`ascc_sim.ros.simulator_node` (the only module here that
imports rospy); ``nodes/simulator`` is a shim calling its ``main()``.
"""
