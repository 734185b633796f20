"""Support code for the stack's rostests (rospy-based; imported by test scripts only).

* ``ascc_testing.waits``: condition waits with timeouts, the newest-message holder,
  the mixin for tests that notify a ``threading.Condition``.
* ``ascc_testing.rosout``: what the nodes under test logged on ``/rosout``, so that a
  bad-input test can assert the promised warning and its throttling.
"""
