"""The operator GUI's Qt widgets (PyQt5). No rospy here: the node's adapter
(``telepresence.ros.operator_gui_node``) feeds them through Qt signals, so every widget
runs offscreen (``QT_QPA_PLATFORM=offscreen``) in tests and benchmarks."""
