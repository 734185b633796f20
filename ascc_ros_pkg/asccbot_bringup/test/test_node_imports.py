"""Every node of the stack imports under the running interpreter: the module behind each
``nodes/`` executable (``<package>.ros.<name>_node`` with rospy, the messages and the pure
code it uses; or a command-line tool's module).

No master is needed. Under ``scripts/test_py38.sh`` (the robots' Python 3.8, with
requirements.txt's 3.8 pins or Ubuntu 20.04's library versions) this checks that the
nodes, not only the pure code, load there: a newer-Python construct or a library API
that 3.8's versions lack fails here.

One skip, named: a compiled module that this machine has for another Python only (Debian
12 builds ``tf2_py._tf2`` and PyQt5's ``sip`` for Python 3.11; on a Noetic robot
``ros-noetic-tf2-py`` and ``python3-pyqt5`` are built for its 3.8). Under Debian's own
interpreter nothing is skipped.
"""
import ast
import glob
import importlib
import importlib.util
import os
import sys
import sysconfig
from pathlib import Path

import pytest

PKGS = Path(__file__).resolve().parents[2]


def node_modules():
    """(executable, module, function) for every ``nodes/`` file that runs a module's
    ``main`` (or ``<tool>_main``)."""
    out = []
    for path in sorted(PKGS.glob("*/nodes/*")):
        tree = ast.parse(path.read_text(), str(path))
        for node in ast.walk(tree):
            if (isinstance(node, ast.ImportFrom) and node.module and node.level == 0
                    and node.module.startswith(path.parts[-3] + ".")
                    and any(a.name == "main" or a.name.endswith("_main")
                            for a in node.names)):
                out += [(path.relative_to(PKGS).as_posix(), node.module, a.name)
                        for a in node.names if a.name.endswith("main")]
    return out


def built_for_other_python(name):
    """The compiled files of module ``name`` when they exist for other Pythons only, or []."""
    parent, _, leaf = name.rpartition(".")
    dirs = []
    if parent:
        try:
            spec = importlib.util.find_spec(parent)
        except ImportError:
            spec = None
        dirs = list(spec.submodule_search_locations or []) if spec else []
    else:
        dirs = [p for p in sys.path if os.path.isdir(p)]
    found = [f for d in dirs for f in glob.glob(os.path.join(d, leaf + ".cpython-*.so"))]
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    if found and not any(f.endswith(suffix) for f in found):
        return found
    return []


def test_every_node_shim_is_checked():
    modules = node_modules()
    assert sum(m.endswith("_node") for _, m, _ in modules) >= 25
    runs_main = [p for p in PKGS.glob("*/nodes/*") if "main()" in p.read_text()]
    assert sorted({e for e, _, _ in modules}) == sorted(
        p.relative_to(PKGS).as_posix() for p in runs_main)


@pytest.mark.parametrize("executable, module, function", node_modules(),
                         ids=[e for e, _, _ in node_modules()])
def test_node_module_imports(executable, module, function):
    try:
        mod = importlib.import_module(module)
    except ImportError as e:
        other = built_for_other_python(e.name or "")
        if other:
            pytest.skip("%s needs %s, built on this machine for another Python only (%s)"
                        % (module, e.name, ", ".join(os.path.basename(f) for f in other)))
        raise
    assert callable(getattr(mod, function, None)), "%s (%s) has no %s()" % (
        module, executable, function)
