"""detect_targets: JSON lines, best first, empty list, exit status, unreadable files."""
import json
import os
import subprocess
import sys

import cv2
import numpy as np

from ascc_common.camera_model import PanoramicCamera
from target_follower import synthetic as S
from target_follower.cli import main

CAM = PanoramicCamera()
NODE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "nodes",
                    "detect_targets")


def write_scenes(tmp_path):
    cone = S.random_scene("cone", 42, CAM).image
    empty = S.random_scene(None, 43, CAM, with_distractors=False).image
    paths = [str(tmp_path / "cone.png"), str(tmp_path / "empty.jpg")]
    cv2.imwrite(paths[0], cone)
    cv2.imwrite(paths[1], empty)
    return paths


def test_json_lines_and_unreadable_file(tmp_path, capsys):
    cone, empty = write_scenes(tmp_path)
    broken = tmp_path / "broken.jpg"
    broken.write_bytes(b"\xff\xd8 no image here")
    status = main(["--kind", "cone", cone, str(broken), empty])
    out, err = capsys.readouterr()
    assert status == 2
    assert str(broken) in err
    lines = [json.loads(line) for line in out.splitlines()]
    assert [d["image"] for d in lines] == [cone, empty]
    dets = lines[0]["detections"]
    assert dets and set(dets[0]) == {"kind", "u", "v", "bbox", "area_px", "score"}
    assert dets[0]["kind"] == "cone" and len(dets[0]["bbox"]) == 4
    assert [d["score"] for d in dets] == sorted((d["score"] for d in dets), reverse=True)
    assert lines[1]["detections"] == []


def test_missing_template_exit_3(tmp_path, capsys):
    cone, _ = write_scenes(tmp_path)
    assert main(["--kind", "logo", "--template", str(tmp_path / "none.png"), cone]) == 3
    assert "none.png" in capsys.readouterr().err


def test_logo_via_the_installed_tool(tmp_path):
    template = cv2.imread(os.path.join(os.path.dirname(NODE), "..", "templates",
                                       "ascc_logo.png"))
    sc = S.random_scene("logo", 44, CAM, template=template)
    path = str(tmp_path / "logo.png")
    cv2.imwrite(path, sc.image)
    res = subprocess.run([sys.executable, NODE, "--kind", "logo", path],
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stderr
    (line,) = res.stdout.splitlines()
    det = json.loads(line)["detections"][0]
    x, y, w, h = sc.targets[0].bbox
    assert x <= det["u"] <= x + w and y <= det["v"] <= y + h
    assert np.isfinite(det["score"])
