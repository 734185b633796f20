"""A ROS 1 bag written with rosbags from raw serialized messages, without rospy: each
connection carries the message's type, md5 and full definition, so `rosbag play` and
`rosbag info` work on it."""
import threading
from dataclasses import dataclass
from typing import Dict, List, Tuple

from rosbags.rosbag1 import Writer

from ascc_common.params import param


def rosbags_type(msgtype: str) -> str:
    """'nav_msgs/Odometry' -> 'nav_msgs/msg/Odometry' (rosbags' naming)."""
    pkg, _, name = msgtype.partition("/")
    return msgtype if "/msg/" in msgtype else "%s/msg/%s" % (pkg, name)


@dataclass
class BagRecorderParams:
    """The bag_recorder node's parameters (private)."""

    path: str = param("run.bag", "the bag's path (~ expanded, relative to the cwd)")
    bz2: bool = param(False, "compress the chunks with bz2")
    topics: List[str] = param(["map", "scan", "odom", "cmd_vel", "/tf", "/tf_static",
                               "sensorPacket", "slam_gmapping/entropy",
                               "frontier_explorer/status", "frontier_explorer/markers",
                               "move_base/goal", "move_base/result", "ground_truth/map",
                               "ground_truth/asccbot/pose"],
                              "topics to record (relative ones resolve in the node's "
                              "namespace)")


class BagRecorder:
    """Thread-safe writer of raw (already serialized) ROS 1 messages into a .bag file."""

    def __init__(self, path: str, bz2: bool = False):
        self.path = path
        self._writer = Writer(path)
        if bz2:
            self._writer.set_compression(Writer.CompressionFormat.BZ2)
        self._writer.open()
        self._connections: Dict[Tuple[str, str], object] = {}
        self._lock = threading.Lock()
        self.messages = 0
        self.closed = False

    def write(self, topic: str, msgtype: str, md5sum: str, msgdef: str, stamp_ns: int,
              raw: bytes, latching: bool = False) -> None:
        with self._lock:
            if self.closed:
                return
            key = (topic, msgtype)
            conn = self._connections.get(key)
            if conn is None:
                conn = self._writer.add_connection(topic, msgtype, msgdef=msgdef,
                                                   md5sum=md5sum,
                                                   latching=1 if latching else None)
                self._connections[key] = conn
            self._writer.write(conn, int(stamp_ns), bytes(raw))
            self.messages += 1

    def close(self) -> None:
        with self._lock:
            if not self.closed:
                self._writer.close()
                self.closed = True
