"""The node `operator_gui` as a process (offscreen) against a real roscore that is not
there yet, comes up, goes away and comes back: the GUI waits without hanging, registers
when the master appears, and registers again with a restarted master."""
import os
import signal
import socket
import subprocess
import sys
import time
import xmlrpc.client
from pathlib import Path

import pytest

from ascc_common.ports import free_port

pytest.importorskip("PyQt5.QtWidgets", reason="PyQt5 comes from Debian/Ubuntu's python3-pyqt5")
NODE = Path(__file__).resolve().parents[1] / "nodes" / "operator_gui"


def port_open(port):
    with socket.socket() as s:
        return s.connect_ex(("127.0.0.1", port)) == 0


def registered(uri):
    """Is /operator_gui known to the master at uri?"""
    try:
        code, _, _ = xmlrpc.client.ServerProxy(uri).lookupNode("/test", "/operator_gui")
    except OSError:
        return False
    return code == 1


def subscribed(uri):
    """Has /operator_gui subscribed to its topics at the master at uri (its start-up done,
    not only ``init_node``)?"""
    try:
        code, _, state = xmlrpc.client.ServerProxy(uri).getSystemState("/test")
    except OSError:
        return False
    return code == 1 and any("/operator_gui" in nodes for topic, nodes in state[1]
                             if topic.endswith("odom"))


def wait(condition, timeout_s, what):
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, "timed out waiting for %s" % what
        time.sleep(0.2)


def roscore(port, env):
    return subprocess.Popen(["roscore", "-p", str(port)], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)


def stop(proc):
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGINT)
        try:
            proc.wait(15)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(5)


def test_ctrl_c_ends_the_wait_for_an_unreachable_master(tmp_path):
    port = free_port()
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", ROS_IP="127.0.0.1",
               ROS_HOME=str(tmp_path))
    log = tmp_path / "stderr.txt"
    with open(log, "w") as err_file:
        gui = subprocess.Popen([sys.executable, str(NODE), "--master",
                                "127.0.0.1:%d" % port], env=env, stdout=subprocess.DEVNULL,
                               stderr=err_file, start_new_session=True)
    try:
        # waiting for the master: Ctrl-C only once it says so (a fixed sleep would ask the
        # start-up to finish within it)
        wait(lambda: "unreachable" in log.read_text(), 20.0,
             "the GUI naming the unreachable master")
        assert gui.poll() is None
        os.killpg(gui.pid, signal.SIGINT)
        gui.wait(10)
    finally:
        stop(gui)
    err = log.read_text()
    assert gui.returncode == 1, err  # cancelled: no robot picked
    assert "unreachable" in err and "Traceback" not in err, err


def test_bad_address_is_named():
    gui = subprocess.run([sys.executable, str(NODE), "--master", "https://x:1/"],
                         env=dict(os.environ, QT_QPA_PLATFORM="offscreen"),
                         capture_output=True, text=True, timeout=30)
    assert gui.returncode == 2 and "address" in gui.stderr


@pytest.mark.skipif(not os.path.exists("/usr/bin/roscore"), reason="needs roscore")
def test_gui_waits_for_the_master_and_registers_again_after_its_restart(tmp_path):
    port = free_port()
    uri = "http://127.0.0.1:%d/" % port
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", ROS_IP="127.0.0.1",
               ROS_MASTER_URI=uri, ROS_HOME=str(tmp_path))
    err = open(tmp_path / "stderr.txt", "w")
    gui = subprocess.Popen([sys.executable, str(NODE), "--master", "127.0.0.1:%d" % port],
                           env=env, stdout=subprocess.DEVNULL, stderr=err,
                           start_new_session=True)
    core = None
    try:
        wait(lambda: "unreachable" in (tmp_path / "stderr.txt").read_text(), 20.0,
             "the GUI naming the unreachable master")
        time.sleep(1.5)
        assert gui.poll() is None, "the GUI ended instead of waiting for the master"
        core = roscore(port, env)
        # all of its start-up done before the master goes (not only init_node: a master
        # gone between the two is another case, start-up against a dying master)
        wait(lambda: subscribed(uri), 40.0, "the GUI subscribed at the master")
        stop(core)
        wait(lambda: not port_open(port), 20.0, "the old master's port closed")
        time.sleep(2.0)
        assert gui.poll() is None, "the GUI ended when the master went away"
        core = roscore(port, env)
        wait(lambda: port_open(port) or core.poll() is not None, 40.0, "the new master")
        assert core.poll() is None, "the new roscore did not start"
        wait(lambda: registered(uri), 40.0, "the GUI registered again (master restarted)")
        assert gui.poll() is None
    finally:
        stop(gui)
        if core is not None:
            stop(core)
        err.close()
    text = (tmp_path / "stderr.txt").read_text()
    assert "Traceback" not in text, text
    assert gui.returncode == 0, text
