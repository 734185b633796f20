"""The simulator node as an importable module with ``main()``: the only code under
``src/`` that imports rospy. ``nodes/simulator`` is a shim that calls ``main()``."""
