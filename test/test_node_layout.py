"""The node layout of docs/DESIGN.md: rospy is imported under ``src/<package>/`` only in the
node subpackage ``ros/``; each ``ros/*_node.py`` has ``main()`` and is not executable
(catkin installs the ``nodes/`` shim); every file in ``nodes/`` either is a shim calling a
``<package>.ros.*_node`` ``main()`` or does not import rospy (a pure command-line tool)."""
import ast
import os
from pathlib import Path

PKGS = Path(__file__).resolve().parents[1] / "ascc_ros_pkg"


def imported_modules(path):
    tree = ast.parse(path.read_text(), str(path))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
    return names, tree


def imports_rospy(names):
    return any(n == "rospy" or n.startswith("rospy.") for n in names)


def test_rospy_only_in_ros_subpackages():
    offenders = []
    for path in sorted(PKGS.glob("*/src/*/**/*.py")):
        if path.relative_to(PKGS).parts[0] == "ascc_testing":
            continue  # the rostests' helpers: ROS test code, not a package's algorithms
        parts = path.relative_to(PKGS).parts  # <package>, "src", <package>, ..., file
        in_ros = len(parts) > 4 and parts[3] == "ros"
        names, _ = imported_modules(path)
        if imports_rospy(names) and not in_ros:
            offenders.append(str(path.relative_to(PKGS)))
        if not in_ros and any(n.split(".")[1:2] == ["ros"] for n in names):
            offenders.append(str(path.relative_to(PKGS)) + " (imports from ros/)")
    assert offenders == []


def test_node_modules_have_main_and_are_not_executable():
    modules = sorted(PKGS.glob("*/src/*/ros/*_node.py"))
    assert len(modules) >= 10
    for path in modules:
        _, tree = imported_modules(path)
        funcs = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
        assert "main" in funcs, path
        assert not os.access(path, os.X_OK), path


def test_nodes_are_shims_or_pure_tools():
    for path in sorted(PKGS.glob("*/nodes/*")):
        pkg = path.parts[-3]
        names, tree = imported_modules(path)
        shim_of = [n for n in names if n.startswith(pkg + ".ros.") and n.endswith("_node")]
        if shim_of:
            assert len(path.read_text().splitlines()) <= 6, path
            assert (PKGS / pkg / "src" / (shim_of[0].replace(".", "/") + ".py")).is_file()
        else:
            assert not imports_rospy(names), "%s: node code belongs in %s.ros" % (path, pkg)
        assert os.access(path, os.X_OK), path
