"""What the nodes under test logged, read from ``/rosout``.

A bad-input test asserts more than survival: the node must say what was wrong, at the
promised level, and no more often than its throttle period. ``RosoutWatcher`` keeps every
``rosgraph_msgs/Log`` record published on ``/rosout`` (every rospy node publishes there)
and answers queries and waits over them.
"""
import threading
import time
from collections import namedtuple

import rospy
from rosgraph_msgs.msg import Log

# level: rosgraph_msgs/Log level (DEBUG 1, INFO 2, WARN 4, ERROR 8, FATAL 16);
# stamp_s: the record's header stamp (ROS time, simulated when use_sim_time);
# wall_s: when this watcher received it (time.monotonic()).
Record = namedtuple("Record", "node level text stamp_s wall_s")

LEVEL = {"debug": Log.DEBUG, "info": Log.INFO, "warn": Log.WARN, "error": Log.ERROR,
         "fatal": Log.FATAL}


class RosoutWatcher:
    """Subscribes ``/rosout`` (absolute: it is the one log topic of the graph) and keeps
    every record. Create it before provoking the node, then ``wait_for`` the record."""

    def __init__(self, queue_size=1000):
        self._records = []
        self._cond = threading.Condition()
        self.sub = rospy.Subscriber("/rosout", Log, self._cb, queue_size=queue_size)

    def _cb(self, msg):
        rec = Record(msg.name, msg.level, msg.msg, msg.header.stamp.to_sec(), time.monotonic())
        with self._cond:
            self._records.append(rec)
            self._cond.notify_all()

    def wait_for_connection(self, timeout_s=10.0):
        """Block until some node's /rosout publisher is connected, so that records logged
        after this call are not lost to subscription set-up."""
        deadline = time.monotonic() + timeout_s
        while self.sub.get_num_connections() == 0:
            if time.monotonic() > deadline or rospy.is_shutdown():
                raise AssertionError("no publisher connected to /rosout after %.0f s"
                                     % timeout_s)
            time.sleep(0.02)

    def matching(self, node=None, level=None, contains=(), since_wall_s=None):
        """Records from ``node`` (resolved name, e.g. "/slam_mapper"; None: any) at
        ``level`` ("warn", "error", ...; None: any) or above whose text contains every
        string of ``contains`` (case-insensitive), received at or after ``since_wall_s``."""
        min_level = LEVEL[level] if level else 0
        needles = [c.lower() for c in ([contains] if isinstance(contains, str) else contains)]
        with self._cond:
            records = list(self._records)
        return [r for r in records
                if (node is None or r.node == node) and r.level >= min_level
                and (since_wall_s is None or r.wall_s >= since_wall_s)
                and all(n in r.text.lower() for n in needles)]

    def wait_for(self, timeout_s, what=None, **filters):
        """Wait (wall-clock ``timeout_s``) until a record matches ``filters`` (see
        ``matching``); return the first. AssertionError naming ``what`` and the node's
        last records otherwise."""
        deadline = time.monotonic() + timeout_s
        with self._cond:
            while True:
                found = self.matching(**filters)
                if found:
                    return found[0]
                left = deadline - time.monotonic()
                if left <= 0 or rospy.is_shutdown():
                    seen = [(r.level, r.text) for r in
                            self.matching(node=filters.get("node"))][-5:]
                    raise AssertionError("no /rosout record %s within %.0f s (%s); last "
                                         "records of that node: %s"
                                         % (what or filters, timeout_s, filters, seen))
                self._cond.wait(min(left, 0.2))


def assert_throttled(records, period_s, start_s, end_s, clock="stamp_s", what="warning"):
    """Check that a throttled log call came, and no more often than its period promises.

    ``records``: the records of one kind (e.g. ``watcher.matching(node=..., contains=...)``);
    those whose ``clock`` value lies in [``start_s``, ``end_s``] are counted. A logger that
    logs at most once per ``period_s`` can log at most floor((end - start) / period) + 1
    times in that window; at least once is required. ``clock``: "stamp_s" (the record's ROS
    time, for ``rospy.log*_throttle``, which throttles on ROS time; the window must not
    contain a jump back of the clock) or "wall_s" (for a node throttling on the wall
    clock; ``wall_s`` is when the record arrived, so ``start_s`` must precede what caused
    the first record). Returns the counted records; AssertionError naming ``what``."""
    times = sorted(getattr(r, clock) for r in records
                   if start_s <= getattr(r, clock) <= end_s)
    window = end_s - start_s
    bound = int(window // period_s) + 1
    if not times:
        raise AssertionError("no %s in the %.2f s window (%s %.2f .. %.2f)"
                             % (what, window, clock, start_s, end_s))
    if len(times) > bound:
        raise AssertionError("%d x %s in a %.2f s window, throttled to one per %.1f s allows "
                             "at most %d (%s offsets %s)"
                             % (len(times), what, window, period_s, bound, clock,
                                ["%.2f" % (t - start_s) for t in times]))
    return [r for r in records if start_s <= getattr(r, clock) <= end_s]
