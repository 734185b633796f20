"""Telepresence of the ASCCbot (thesis chapter 4): the velocity priority mux, the
simulated Kinect skeleton and gesture recognition.

Pure code (no rospy); the nodes live in ``telepresence.ros``."""
