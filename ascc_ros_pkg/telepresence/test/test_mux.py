"""The velocity mux's rules (telepresence.mux): priority, timeout, locks, configuration."""
import pytest
import yaml

from telepresence.mux import IDLE, STOP, MuxInput, VelocityMux, parse_config, parse_entries

CONFIG = """
topics:
- {name: navigation, topic: nav/cmd_vel, timeout: 0.5, priority: 10}
- {name: teleop, topic: teleop/cmd_vel, timeout: 0.5, priority: 100}
- {name: gesture, topic: gesture/cmd_vel, timeout: 0.5, priority: 200}
locks:
- {name: e_stop, topic: e_stop, timeout: 0.0, priority: 255}
- {name: pause_nav, topic: pause_navigation, timeout: 0.0, priority: 100}
"""


def make_mux(locks=True):
    cfg = yaml.safe_load(CONFIG)
    inputs, lock_list = parse_config(cfg["topics"], cfg["locks"] if locks else None)
    return VelocityMux(inputs, lock_list)


def test_parse_reads_twist_muxs_format():
    mux = make_mux()
    assert [m.name for m in mux.inputs] == ["navigation", "teleop", "gesture"]
    assert mux.inputs[1] == MuxInput("teleop", "teleop/cmd_vel", 0.5, 100)
    assert [m.priority for m in mux.locks] == [255, 100]


def test_parse_accepts_the_ros2_layout_name_to_entry():
    inputs = parse_entries({"nav": {"topic": "a", "timeout": 1, "priority": 3}}, "topics")
    assert inputs == [MuxInput("nav", "a", 1.0, 3)]


@pytest.mark.parametrize("entries, words", [
    ([{"name": "a", "topic": "t", "timeout": 0.5}], "lacks priority"),
    ([{"name": "a", "topic": "t", "timeout": -1, "priority": 1}], "timeout"),
    ([{"name": "a", "topic": "t", "timeout": float("nan"), "priority": 1}], "timeout"),
    ([{"name": "a", "topic": "t", "timeout": 0.5, "priority": 256}], "priority"),
    ([{"name": "a", "topic": "t", "timeout": 0.5, "priority": 1.5}], "priority"),
    ([{"name": "", "topic": "t", "timeout": 0.5, "priority": 1}], "non-empty"),
    ([{"name": "a", "topic": "t", "timeout": 0.5, "priority": 1}] * 2, "repeated: a"),
    (["teleop"], "must be a dict"),
    ("teleop", "must be a list"),
])
def test_parse_names_the_bad_entry(entries, words):
    with pytest.raises(ValueError, match=words):
        parse_entries(entries, "topics")


def test_no_input_is_an_error():
    with pytest.raises(ValueError, match="no velocity input"):
        parse_config(None, None)


def test_highest_fresh_priority_wins_and_lower_is_not_forwarded():
    mux = make_mux()
    assert mux.select(0.0) == IDLE
    assert mux.on_command("navigation", 0.0, "nav")
    assert mux.on_command("teleop", 0.1, "tele")
    assert mux.active == "teleop"
    assert not mux.on_command("navigation", 0.2, "nav")  # masked by the fresher teleop
    assert mux.on_command("gesture", 0.3, "gest")
    assert not mux.on_command("teleop", 0.35, "tele")
    assert mux.select(0.4) == "gesture"


def test_equal_priorities_first_in_the_list_wins():
    mux = VelocityMux([MuxInput("a", "a", 1.0, 5), MuxInput("b", "b", 1.0, 5)])
    mux.on_command("b", 0.0, "b")
    assert mux.select(0.0) == "b"
    mux.on_command("a", 0.1, "a")
    assert mux.select(0.1) == "a"
    assert not mux.on_command("b", 0.2, "b")


def test_stale_input_hands_over_to_the_next_with_its_newest_command():
    mux = make_mux()
    mux.on_command("teleop", 0.0, "tele0")
    mux.on_command("gesture", 0.1, "gest")
    mux.on_command("teleop", 0.4, "tele1")
    assert mux.tick(0.55) is None  # gesture 0.45 s old: fresh (timeout 0.5 s)
    assert mux.tick(0.65) == "tele1"  # gesture stale: teleop's newest, at once
    assert mux.active == "teleop"


def test_stale_active_input_stops_the_robot_once():
    mux = make_mux()
    mux.on_command("teleop", 0.0, "tele")
    assert mux.tick(0.5) is None  # exactly the timeout: not yet stale
    assert mux.tick(0.51) == STOP
    assert mux.active == IDLE
    assert mux.tick(0.6) is None  # once only
    assert mux.tick(5.0) is None


def test_timeout_zero_never_goes_stale_but_needs_a_first_command():
    mux = VelocityMux([MuxInput("latched", "l", 0.0, 1)])
    assert mux.select(100.0) == IDLE
    mux.on_command("latched", 0.0, "x")
    assert mux.select(1e6) == "latched"


def test_lock_masks_lower_priorities_and_stops_the_robot():
    mux = make_mux()
    mux.on_command("gesture", 0.0, "gest")
    assert mux.on_lock("e_stop", 0.1, True) == STOP
    assert not mux.on_command("gesture", 0.2, "gest")  # 200 < 255: masked
    assert mux.engaged_locks(0.2) == ["e_stop"]
    # released: gesture's command (0.1 s old, fresh) has the base again at once
    assert mux.on_lock("e_stop", 0.3, False) == "gest"
    assert mux.active == "gesture"


def test_lock_released_hands_the_base_to_the_fresh_input_at_once():
    mux = make_mux()
    mux.on_lock("e_stop", 0.0, True)
    mux.on_command("teleop", 0.1, "tele")
    assert mux.active == IDLE
    assert mux.on_lock("e_stop", 0.2, False) == "tele"
    assert mux.active == "teleop"


def test_lock_of_equal_priority_does_not_mask():
    mux = make_mux()
    mux.on_lock("pause_nav", 0.0, True)  # priority 100 = teleop's
    assert not mux.on_command("navigation", 0.1, "nav")
    assert mux.on_command("teleop", 0.2, "tele")
    assert mux.on_command("gesture", 0.3, "gest")


def test_lock_with_timeout_is_a_heartbeat():
    mux = VelocityMux([MuxInput("teleop", "t", 0.5, 100)],
                      [MuxInput("deadman", "d", 0.2, 150)])
    mux.on_command("teleop", 0.0, "tele")
    assert mux.active == IDLE  # engaged until its first false
    assert mux.on_lock("deadman", 0.05, False) == "tele"
    assert mux.tick(0.2) is None
    assert mux.tick(0.3) == STOP  # the heartbeat stopped: engaged
    assert mux.engaged_locks(0.3) == ["deadman"]


def test_unknown_names_are_errors_and_reset_forgets():
    mux = make_mux()
    with pytest.raises(KeyError):
        mux.on_command("joystick", 0.0, "x")
    with pytest.raises(KeyError):
        mux.on_lock("nope", 0.0, True)
    mux.on_command("teleop", 0.0, "tele")
    mux.reset()
    assert mux.active == IDLE and mux.select(0.1) == IDLE
    assert mux.last_command("teleop") is None
