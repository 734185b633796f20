"""A rospy publisher that writes in the caller's thread and never blocks it.

rospy's ``Publisher(queue_size=N)`` gives every subscriber connection its own writer thread:
each message wakes one thread per subscriber. The driver's odometry TF goes out at 30 Hz to
every TF listener of the stack (three in the exploration stack), and those wake-ups cost it
about a quarter of its CPU (docs/results/irobot_create_2_1.md, "Driver CPU").
``queue_size=None`` writes in the caller's thread instead, but then ``socket.sendall``
blocks the caller as soon as one subscriber stops reading (a stopped process, a debugger at
a breakpoint) and its socket buffers fill. In the driver the caller is the thread that also
runs the command watchdog, so a blocked publish would leave the robot driving.

``InlinePublisher`` publishes synchronously but first asks the kernel (``poll``, no wait)
which subscribers' sockets have room. While all have (the normal case) the message is
serialized once and written to each. A subscriber whose socket has no room is skipped: it
misses messages until it reads again, as a full rospy queue drops them. Skips are counted
per subscriber (``skipped``) and reported through ``on_skip``, so the node can warn.

Why a socket with room does not block: Linux reports a TCP socket writable only while its
free send space is at least half of what is queued, i.e. at least a third of its send
buffer (4 KiB at the very least, 16 KiB initially), more than one message of the sizes
this is used for (an odometry TF: about 100 bytes; an Odometry: about 730 bytes). Only the
publishing thread writes to these connections (rospy writes a latched message to a new
connection from its own thread; this publisher is not latched), and every write holds
rospy's per-topic publish lock, as ``rospy.Publisher.publish`` does.

It relies on rospy's publisher internals (as in Noetic, ROS 1's last release):
``Publisher.impl`` (``connections``, copied on change; ``publock``; ``publish(msg,
connection_override=c)``) and a TCPROS connection's ``socket`` and ``endpoint_id``.
"""
import select
import warnings

import rospy

_READY = select.POLLOUT
_GONE = select.POLLERR | select.POLLHUP | select.POLLNVAL


class InlinePublisher:
    """``rospy.Publisher(name, data_class, queue_size=None)`` that skips subscribers whose
    socket has no room instead of blocking. ``on_skip(endpoint_id, count)``: called (in the
    publishing thread) each time a subscriber is skipped, ``count`` its skips so far.
    ``publish`` takes a message instance of ``data_class`` (not rospy's field arguments)
    and is meant for one publishing thread."""

    def __init__(self, name, data_class, on_skip=None, **kwargs):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SyntaxWarning)  # rospy's "no queue_size" warning
            self.pub = rospy.Publisher(name, data_class, queue_size=None, **kwargs)
        self.on_skip = on_skip
        self.skipped = {}  # endpoint id -> messages it missed so far

    def get_num_connections(self):
        return self.pub.get_num_connections()

    def publish(self, msg):
        """Write ``msg`` to every subscriber whose socket has room; returns the number of
        subscribers skipped."""
        impl = self.pub.impl
        if impl is None:
            raise rospy.ROSException("publish() to an unregistered publisher of %s"
                                     % self.pub.resolved_name)
        conns = impl.connections  # rospy replaces the list on a change: a stable snapshot
        if not conns:
            return 0
        full = self._full(conns)
        with impl.publock:
            if not full:
                impl.publish(msg)
                return 0
            for c in conns:
                if c not in full:
                    impl.publish(msg, connection_override=c)
        for c in full:
            who = getattr(c, "endpoint_id", None) or "?"
            self.skipped[who] = self.skipped.get(who, 0) + 1
            if self.on_skip is not None:
                self.on_skip(who, self.skipped[who])
        return len(full)

    @staticmethod
    def _full(conns):
        """The connections whose socket has no room for a message now."""
        poller = select.poll()
        by_fd = {}
        for c in conns:
            sock = getattr(c, "socket", None)
            if sock is None:
                continue  # not (yet) a TCPROS socket: rospy's write handles it
            try:
                fd = sock.fileno()
            except OSError:
                continue  # closed: rospy's write reports it and drops the connection
            if fd < 0:
                continue
            poller.register(fd, _READY)
            by_fd[fd] = c
        ready = {fd for fd, ev in poller.poll(0) if ev & (_READY | _GONE)}
        # an error or hang-up goes to rospy's write, which closes the connection
        return [c for fd, c in by_fd.items() if fd not in ready]
