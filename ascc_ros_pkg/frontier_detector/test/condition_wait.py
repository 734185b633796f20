"""Test helper shared by the rostests: wait on `self.cond` until a predicate holds.

The test case's subscriber callbacks update its state under `self.cond` and call
`notify_all()`; `wait_for` re-checks the predicate on every notification (and at least
every 0.5 s), with a timeout in ROS time and no fixed sleeps.
"""

import rospy


class ConditionWaitMixin:
    """Mixin for unittest.TestCase; expects `self.cond` (threading.Condition) and
    `self.statuses` (the explorer's status strings so far, quoted in a timeout)."""

    def wait_for(self, predicate, timeout_s, what):
        deadline = rospy.get_time() + timeout_s
        with self.cond:
            while not predicate():
                left = deadline - rospy.get_time()
                if left <= 0 or rospy.is_shutdown():
                    self.fail("timed out waiting for %s (statuses %s)" % (what, self.statuses))
                self.cond.wait(min(left, 0.5))
