"""A bag written by BagRecorder, read back with rosbags."""
import struct

import pytest
from rosbags.rosbag1 import Reader

from ascc_common.params import ParamError, from_params
from ascc_eval.bagfile import BagRecorder, BagRecorderParams

FLOAT64_DEF = "float64 data\n"
FLOAT64_MD5 = "fdb28210bfa9d7c91146260178d9a584"  # std_msgs/Float64


def test_bag_round_trip(tmp_path):
    path = str(tmp_path / "run.bag")
    rec = BagRecorder(path)
    for i in range(5):
        rec.write("entropy", "std_msgs/msg/Float64", FLOAT64_MD5, FLOAT64_DEF,
                  1_000_000_000 + i * 100_000_000, struct.pack("<d", 0.5 * i))
    rec.close()
    rec.write("entropy", "std_msgs/msg/Float64", FLOAT64_MD5, FLOAT64_DEF, 0, b"")  # ignored
    with Reader(path) as reader:
        conns = list(reader.connections)
        assert [c.topic for c in conns] == ["entropy"]
        assert conns[0].digest == FLOAT64_MD5
        values = [struct.unpack("<d", raw)[0] for _, _, raw in reader.messages()]
    assert values == [0.0, 0.5, 1.0, 1.5, 2.0]


def test_recorder_topics_are_a_list_of_names():
    p = from_params(BagRecorderParams, {}.get)
    assert p.topics[:4] == ["map", "scan", "odom", "cmd_vel"] and len(p.topics) == 14
    assert from_params(BagRecorderParams, {"topics": ["a", "/b"]}.get).topics == ["a", "/b"]
    with pytest.raises(ParamError, match="parameter topics: expected list of str, got 'map'"):
        from_params(BagRecorderParams, {"topics": "map"}.get)
