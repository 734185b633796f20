"""Every rviz config against the launch file that shows it: each display's plugin exists
(rviz's plugin description), each enabled display's topic is published with a type that
display takes, its robot description parameter is set, the fixed frame and every frame
the TF display expects are in TF, and the markers of its marker displays are drawable
(``ascc_testing.markers``) over MARKER_WATCH_S. rviz itself is not started (no display needed):
these are the errors rviz would show in its Displays panel (a missing topic or type,
"Fixed Frame [map] does not exist", a plugin that is not found).

Each launch runs on its own master on a free loopback port (scripts/ros_isolation.sh),
CHECK_JOBS of them at once (they mostly wait: 105 s for the eight entries instead of ~190).
``scripts/rviz_screenshots.py`` renders the same configs with the same launch files.
"""
import concurrent.futures
import importlib.util
import os
import subprocess
import time
import xml.etree.ElementTree as ET
import xmlrpc.client

import pytest
import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RVIZ_PLUGINS = "/usr/share/rviz/plugin_description.xml"

# the screenshot script's helpers: the launches of rviz/launches.yaml, isolated runs
_spec = importlib.util.spec_from_file_location(
    "rviz_screenshots", os.path.join(ROOT, "scripts", "rviz_screenshots.py"))
shots = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(shots)
# entry of rviz/launches.yaml -> (config, the launch file that shows it, its arguments);
# a config may have several entries (exploration.rviz: the demo and the robot's bring-up)
CONFIGS = {name: ("rviz/" + spec["config"], spec["launch"], spec["args"])
           for name, spec in shots.load_specs().items()}
# display class -> (topic key, accepted message types); None: no topic
DISPLAY_TYPES = {
    "rviz/Grid": None, "rviz/TF": None, "rviz/RobotModel": None,
    "rviz/Map": ("Topic", {"nav_msgs/OccupancyGrid"}),
    "rviz/MarkerArray": ("Marker Topic", {"visualization_msgs/MarkerArray"}),
    "rviz/Path": ("Topic", {"nav_msgs/Path"}),
    "rviz/Pose": ("Topic", {"geometry_msgs/PoseStamped"}),
    "rviz/LaserScan": ("Topic", {"sensor_msgs/LaserScan"}),
    "rviz/Odometry": ("Topic", {"nav_msgs/Odometry"}),
    "rviz/Image": ("Image Topic", {"sensor_msgs/Image"}),
    "rviz/PointStamped": ("Topic", {"geometry_msgs/PointStamped"}),
    "rviz/Polygon": ("Topic", {"geometry_msgs/PolygonStamped"}),
}
FRAMES_SNIPPET = """
import sys, time, rospy, tf2_ros, yaml
rospy.init_node("rviz_config_check", anonymous=True)
buf = tf2_ros.Buffer(); tf2_ros.TransformListener(buf)
want = sys.argv[1:]
deadline = time.time() + 90
while time.time() < deadline:
    frames = yaml.safe_load(buf.all_frames_as_yaml()) or {}
    names = set(frames) | {f["parent"] for f in frames.values()}
    if all(w in names for w in want):
        break
    time.sleep(1)
print(" ".join(sorted(names)))
"""

MARKERS_SNIPPET = """
import sys, time, rospy
from visualization_msgs.msg import MarkerArray
from ascc_testing.markers import marker_array_errors
rospy.init_node("rviz_marker_check", anonymous=True)
errors = set()
for topic in sys.argv[2:]:
    rospy.Subscriber(topic, MarkerArray, lambda m, t=topic: errors.update(
        "%s: %s" % (t, e) for e in marker_array_errors(m)), queue_size=20)
time.sleep(float(sys.argv[1]))
print("\\n".join(sorted(errors)))
"""
MARKER_WATCH_S = 15.0  # wall time over which the marker topics are checked


def _displays(items):
    for d in items:
        yield d
        yield from _displays(d.get("Displays", []))


def _config(path):
    with open(os.path.join(ROOT, path)) as f:
        manager = yaml.safe_load(f)["Visualization Manager"]
    return manager, list(_displays(manager["Displays"]))


def test_every_config_is_checked_and_its_plugins_exist():
    paths = sorted({path for path, _, _ in CONFIGS.values()})
    assert paths == sorted("rviz/" + f for f in os.listdir(os.path.join(ROOT, "rviz"))
                           if f.endswith(".rviz"))
    classes = {c.get("name") for c in ET.parse(RVIZ_PLUGINS).getroot().iter("class")}
    for path in paths:
        _, displays = _config(path)
        for d in displays:
            assert d["Class"] in classes, (path, d["Class"])
            assert d["Class"] in DISPLAY_TYPES, "%s: add %s to DISPLAY_TYPES" % (path,
                                                                                  d["Class"])


def _wait_for_topics(master, wanted, deadline):
    types = None  # None until the master answers
    while time.time() < deadline:
        try:
            types = dict(master.getTopicTypes("/rviz_config_check")[2])
        except OSError:
            pass
        if types is not None and all(t in types for t in wanted):
            break
        time.sleep(2)
    return types or {}


def _description_problems(master, displays):
    problems = []
    for d in displays:
        if d["Class"] == "rviz/RobotModel" and d.get("Enabled", True):
            code, _, urdf = master.getParam("/rviz_config_check", "/" + d["Robot Description"])
            if code != 1 or "<robot" not in urdf:
                problems.append("%s: no robot description" % d["Name"])
    return problems


def _check(entry):
    """The problems rviz would show for ``entry`` of rviz/launches.yaml (its config with
    its launch file running on an isolated master), or the launch's early end."""
    path, launch, args = CONFIGS[entry]
    manager, displays = _config(path)
    env = shots.isolated_env()
    wanted = {}
    for d in displays:
        spec = DISPLAY_TYPES[d["Class"]]
        if spec and d.get("Enabled", True):
            topic = d[spec[0]]
            wanted["/" + topic.lstrip("/")] = (spec[1], d["Name"])
    args = [a.replace("FREE", str(shots.free_port())) for a in args]
    run = subprocess.Popen(["bash", "-c", "source env.sh; exec roslaunch %s %s"
                            % (launch, " ".join(args))], cwd=ROOT, env=env,
                           stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT,
                           start_new_session=True)
    try:
        master = xmlrpc.client.ServerProxy(env["ROS_MASTER_URI"])
        types = _wait_for_topics(master, wanted, time.time() + 150)
        problems = ["%s (%s): %s" % (topic, name, "not published" if topic not in types else
                                     "type %s, the display takes %s" % (types[topic],
                                                                        sorted(accepted)))
                    for topic, (accepted, name) in wanted.items()
                    if types.get(topic) not in accepted]
        # what would turn a marker display red, watched while TF is checked
        marker_topics = ["/" + d["Marker Topic"].lstrip("/") for d in displays
                         if d["Class"] == "rviz/MarkerArray" and d.get("Enabled", True)]
        watcher = None
        if marker_topics:
            watcher = subprocess.Popen(["python3", "-c", MARKERS_SNIPPET, str(MARKER_WATCH_S)]
                                       + marker_topics, cwd=ROOT, env=env, text=True,
                                       stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
        want_frames = [manager["Global Options"]["Fixed Frame"]]
        for d in displays:
            if d["Class"] == "rviz/TF":
                want_frames += [f for f, v in d.get("Frames", {}).items()
                                if isinstance(v, dict) and v.get("Value")]
        names = subprocess.run(["python3", "-c", FRAMES_SNIPPET] + want_frames, cwd=ROOT,
                               env=env, capture_output=True, text=True,
                               timeout=150).stdout.split()
        problems += ["frame %s not in TF" % f for f in want_frames if f not in names]
        if watcher is not None:
            out, _ = watcher.communicate(timeout=MARKER_WATCH_S + 60)
            problems += [line for line in out.splitlines() if line.strip()]
        problems += _description_problems(master, displays)  # after TF: params are set
        if run.poll() is not None:
            problems.append("%s ended" % launch)
        return "%s with %s" % (path, launch), problems
    finally:
        if run.poll() is None:
            os.killpg(run.pid, 2)
        try:
            run.wait(timeout=60)
        except subprocess.TimeoutExpired:
            os.killpg(run.pid, 9)


# The checks wait most of their time (a launch coming up, TF, MARKER_WATCH_S of markers):
# CHECK_JOBS of them run at once, each on its own master.
CHECK_JOBS = 3


@pytest.fixture(scope="module")
def checks(request):
    """entry -> future of ``_check(entry)``, for every entry this session runs."""
    wanted = sorted({item.callspec.params["entry"] for item in request.session.items
                     if item.originalname == "test_config_against_its_launch"})
    with concurrent.futures.ThreadPoolExecutor(CHECK_JOBS) as pool:
        futures = {}
        for entry in wanted:
            futures[entry] = pool.submit(_check, entry)
            time.sleep(1.0)  # free ports picked apart
        yield futures


@pytest.mark.parametrize("entry", sorted(CONFIGS))
def test_config_against_its_launch(entry, checks):
    what, problems = checks[entry].result()
    assert problems == [], "%s:\n%s" % (what, "\n".join(problems))
