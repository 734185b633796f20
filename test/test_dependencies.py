"""Every package declares what its code imports (the robot's dependency route: ``rosdep
install --from-paths`` installs exactly the package.xml keys), and the keys rosdistro does
not define are in the project's own rosdep source, ``rosdep/asccbot.yaml``.

An imported module is the standard library's, a ROS package's (its key is its name), one
of the third-party modules in ``PYTHON_KEYS`` (its rosdep key), or a sibling script. Any
other module fails the test until it is classified here.
"""
import ast
import importlib.util
import os
import sysconfig
import xml.etree.ElementTree as ET
from pathlib import Path

import rospkg
import yaml

ROOT = Path(__file__).resolve().parents[1]
PKGS = ROOT / "ascc_ros_pkg"
# third-party Python modules -> rosdep key (Noetic / Ubuntu 20.04 names)
PYTHON_KEYS = {"numpy": "python3-numpy", "cv2": "python3-opencv", "yaml": "python3-yaml",
               "matplotlib": "python3-matplotlib", "serial": "python3-serial",
               "rosbags": "python3-rosbags-pip", "rospkg": "python3-rospkg",
               "scipy": "python3-scipy", "sklearn": "python3-sklearn",
               "hmmlearn": "python3-hmmlearn-pip", "joblib": "python3-joblib",
               "numba": "python3-numba",
               "PyQt5": "python3-pyqt5",
               "tornado": "python3-tornado", "selenium": "python3-selenium",
               # a ROS package that Debian ships without its package.xml
               "diagnostic_updater": "diagnostic_updater"}
STDLIB = os.path.realpath(sysconfig.get_paths()["stdlib"])


def _is_stdlib(name):
    spec = importlib.util.find_spec(name)
    if spec is None:
        return False
    origin = spec.origin or ""
    if origin in ("built-in", "frozen"):
        return True
    path = os.path.realpath(origin)
    return path.startswith(STDLIB) and "-packages" not in path


def _imports(pkg):
    names = set()
    files = [p for p in (list((pkg / "src").rglob("*.py")) + list((pkg / "nodes").glob("*"))
                         + list((pkg / "scripts").glob("*"))) if p.is_file()]
    for path in files:
        try:
            tree = ast.parse(path.read_text(), str(path))
        except (SyntaxError, UnicodeDecodeError):
            continue  # not Python (shell scripts)
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                names.update(a.name.split(".")[0] for a in node.names)
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                names.add(node.module.split(".")[0])
    siblings = {p.stem for p in (pkg / "scripts").glob("*.py")}
    return names - siblings - {"__future__", pkg.name}


def _declared(pkg):
    root = ET.parse(pkg / "package.xml").getroot()
    return {el.text.strip() for el in root if el.tag.endswith("depend") and el.text}


def test_every_import_is_declared():
    rospack, problems = rospkg.RosPack(), []
    for pkg in sorted(p.parent for p in PKGS.glob("*/package.xml")):
        declared = _declared(pkg)
        for module in sorted(_imports(pkg)):
            if module in PYTHON_KEYS:
                key = PYTHON_KEYS[module]
            elif _is_stdlib(module):
                continue
            else:
                try:
                    rospack.get_path(module)
                except rospkg.ResourceNotFound:
                    problems.append("%s imports %s: not stdlib, not a ROS package, not in "
                                    "PYTHON_KEYS" % (pkg.name, module))
                    continue
                key = module
            if key not in declared:
                problems.append("%s imports %s but its package.xml lacks %s"
                                % (pkg.name, module, key))
    assert problems == [], "\n".join(problems)


def test_pip_keys_are_in_the_project_rosdep_source():
    with open(ROOT / "rosdep" / "asccbot.yaml") as f:
        source = yaml.safe_load(f)
    used = set().union(*(_declared(p.parent) for p in PKGS.glob("*/package.xml")))
    pip_keys = {k for k in used if k.endswith("-pip")}
    assert pip_keys and pip_keys <= set(source)
    for key in pip_keys:
        assert source[key]["ubuntu"]["pip"]["packages"], key
