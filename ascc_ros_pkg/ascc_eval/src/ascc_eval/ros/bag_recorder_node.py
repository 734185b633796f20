"""bag_recorder: records topics into a ROS 1 bag written with rosbags (no rosbag C++ API).

Subscribes to every topic of `~topics` (list of names, relative ones resolve in the node's
namespace) as rospy.AnyMsg and writes the raw bytes with the publisher's type, md5 and
message definition, so `rosbag play`/`rosbag info` read the result. `~path` (default
`run.bag`), `~bz2` (false), `~topics`: ``ascc_eval.bagfile.BagRecorderParams``. The bag is
closed on shutdown.
"""
import os

import rospy

from ascc_common.params import from_params
from ascc_eval.bagfile import BagRecorder, BagRecorderParams, rosbags_type


class Recorder:
    def __init__(self):
        p = from_params(BagRecorderParams, rospy.get_param, "~")
        path = os.path.abspath(os.path.expanduser(p.path))
        os.makedirs(os.path.dirname(path), exist_ok=True)
        self.bag = BagRecorder(path, bz2=p.bz2)
        for topic in p.topics:
            name = rospy.resolve_name(topic)
            rospy.Subscriber(name, rospy.AnyMsg, self.on_msg, callback_args=name,
                             queue_size=100)
        rospy.on_shutdown(self.close)
        rospy.loginfo("bag_recorder: recording to %s", path)

    def on_msg(self, msg, topic):
        header = getattr(msg, "_connection_header", None) or {}
        if "type" not in header:
            rospy.logwarn_throttle(10.0, "bag_recorder: %s: no type in the connection "
                                   "header; message not recorded" % topic)
            return
        self.bag.write(topic, rosbags_type(header["type"]), header.get("md5sum", ""),
                       header.get("message_definition", ""), rospy.Time.now().to_nsec(),
                       msg._buff, latching=header.get("latching") == "1")

    def close(self):
        self.bag.close()
        rospy.loginfo("bag_recorder: %d messages written to %s", self.bag.messages,
                      self.bag.path)


def main():
    rospy.init_node("bag_recorder")
    Recorder()
    rospy.spin()
