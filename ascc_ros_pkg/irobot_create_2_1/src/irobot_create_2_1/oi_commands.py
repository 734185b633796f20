"""Open Interface commands for the emulated Create: framing the host's bytes into commands,
which OI modes accept each, and decoding each command's data bytes into an action of the
robot (pure Python).

:func:`take_command` cuts the next command off the input queue; :data:`COMMANDS` maps an
opcode to its handler and modes; a handler decodes the data bytes and calls the robot:
:class:`irobot_create_2_1.create_state.CreateState` actions (drive, LEDs, songs, ...) or the
emulator's own (sensor replies, stream, script, waits) on
:class:`irobot_create_2_1.virtual_create.VirtualCreate`. Opcodes and data-byte counts come
from :mod:`irobot_create_2_1.protocol`.

Behaviour choices where the spec is silent or where we deliberately differ:

* Off mode listens only for Start (128): every other byte is discarded one by one, like the
  robot's OI that is not started yet. In passive/safe/full, commands are framed by their
  lengths; commands not allowed in the current mode are consumed and ignored; unknown
  opcodes are skipped one byte at a time.
* Song with a number above 15 or 0 / more than 16 notes, Script longer than 100 bytes and a
  Baud code above 11 are consumed and ignored.
* Stream with 0 packets stops the stream. An unknown Wait Event id ends the wait at once.
* Create 2 (:data:`CREATE_2_COMMANDS`): Max (136, no data byte) runs like Cover; Seek Dock
  (143) like Cover-and-Dock; Reset (7) and Stop (173) power-cycle the OI (off: Start
  only), Power (133) drops to passive; Drive PWM, the scheduling/digit LEDs, Buttons,
  Schedule and Set Day/Time are consumed and ignored; the Create 1's scripts, waits,
  digital outputs and Send IR are unknown opcodes there.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable, Dict, Optional, Tuple

from irobot_create_2_1 import protocol
from irobot_create_2_1.create_state import (
    DEMO_COVER,
    DEMO_COVER_AND_DOCK,
    DEMO_SPOT_COVER,
    FULL,
    OFF,
    PASSIVE,
    SAFE,
    CreateState,
)

if TYPE_CHECKING:
    from irobot_create_2_1.virtual_create import VirtualCreate

SCRIPT_MAX_BYTES = 100
SONG_SLOTS = 16                  # songs 0..15
WAIT_TIME_TICK_S = 0.1           # Wait Time argument is in 0.1 s

ANY_MODE = (OFF, PASSIVE, SAFE, FULL)
STARTED = (PASSIVE, SAFE, FULL)
ACTUATING = (SAFE, FULL)

Handler = Callable[["VirtualCreate", bytes], None]


def int16(data: bytes) -> int:
    return int.from_bytes(data, "big", signed=True)


def int8(value: int) -> int:
    return value - 256 if value > 127 else value


def _song(robot: VirtualCreate, args: bytes) -> None:
    number, length = args[0], args[1]
    if number >= SONG_SLOTS or not 1 <= length <= protocol.MAX_SONG_NOTES:
        return                               # out of spec: consumed, ignored
    notes = args[2:2 + 2 * length]
    robot.define_song(number, [(notes[i], notes[i + 1]) for i in range(0, len(notes), 2)])


def _script(robot: VirtualCreate, args: bytes) -> None:
    length = args[0]
    if length <= SCRIPT_MAX_BYTES:
        robot.script = bytes(args[1:1 + length])


def _wait_distance(robot: VirtualCreate, args: bytes) -> None:
    robot.reset_distance()                   # the spec: resets the distance variable
    robot.start_wait("distance", int16(args))


def _wait_angle(robot: VirtualCreate, args: bytes) -> None:
    robot.reset_angle()
    robot.start_wait("angle", int16(args))


def _pause_resume(robot: VirtualCreate, args: bytes) -> None:
    if args[0] in (0, 1):
        robot.pause_resume_stream(args[0] == 1)


#: opcode -> (handler(robot, data bytes), OI modes in which the command is executed).
COMMANDS: Dict[int, Tuple[Handler, Tuple[int, ...]]] = {
    protocol.START: (lambda r, a: r.enter_passive(), ANY_MODE),
    protocol.BAUD: (lambda r, a: r.set_baud(a[0]), STARTED),
    protocol.CONTROL: (lambda r, a: r.enter_safe(), STARTED),  # the old SCI name of Safe
    protocol.SAFE: (lambda r, a: r.enter_safe(), STARTED),
    protocol.FULL: (lambda r, a: r.enter_full(), STARTED),
    protocol.SPOT: (lambda r, a: r.start_demo(DEMO_SPOT_COVER), STARTED),
    protocol.COVER: (lambda r, a: r.start_demo(DEMO_COVER), STARTED),
    protocol.COVER_AND_DOCK: (lambda r, a: r.start_demo(DEMO_COVER_AND_DOCK), STARTED),
    protocol.DEMO: (lambda r, a: r.start_demo(int8(a[0])), STARTED),
    protocol.DRIVE: (lambda r, a: r.drive(int16(a[0:2]), int16(a[2:4])), ACTUATING),
    # Drive Direct: the right wheel comes first on the wire.
    protocol.DRIVE_DIRECT: (lambda r, a: r.drive_direct(int16(a[2:4]), int16(a[0:2])),
                            ACTUATING),
    protocol.LOW_SIDE_DRIVERS: (lambda r, a: r.set_low_side_drivers(a[0]), ACTUATING),
    protocol.PWM_LOW_SIDE_DRIVERS: (lambda r, a: r.set_pwm_low_side(tuple(a[:3])), ACTUATING),
    protocol.DIGITAL_OUTPUTS: (lambda r, a: r.set_digital_outputs(a[0]), ACTUATING),
    protocol.SEND_IR: (lambda r, a: r.send_ir(a[0]), ACTUATING),
    protocol.LEDS: (lambda r, a: r.set_leds(a[0], a[1], a[2]), ACTUATING),
    protocol.SONG: (_song, STARTED),
    protocol.PLAY: (lambda r, a: r.play_song(a[0]), ACTUATING),
    protocol.SENSORS: (lambda r, a: r.send_sensors(a[0:1]), STARTED),
    protocol.QUERY_LIST: (lambda r, a: r.send_sensors(a[1:]), STARTED),
    protocol.STREAM: (lambda r, a: r.start_stream(list(a[1:])), STARTED),
    protocol.PAUSE_RESUME_STREAM: (_pause_resume, STARTED),
    protocol.SCRIPT: (_script, STARTED),
    protocol.PLAY_SCRIPT: (lambda r, a: r.play_script(), STARTED),
    protocol.SHOW_SCRIPT: (lambda r, a: r.show_script(), STARTED),
    protocol.WAIT_TIME: (lambda r, a: r.start_wait("time", a[0] * WAIT_TIME_TICK_S), STARTED),
    protocol.WAIT_DISTANCE: (_wait_distance, STARTED),
    protocol.WAIT_ANGLE: (_wait_angle, STARTED),
    protocol.WAIT_EVENT: (lambda r, a: r.start_wait("event", int8(a[0])), STARTED),
}

def _ignored(robot: VirtualCreate, args: bytes) -> None:
    """A command of the Create 2 OI that is consumed but not emulated."""


#: The Create 2 (Roomba 600 OI): the Create 1's commands less those it lacks, Max instead
#: of Demo (no data byte), and its own commands; those not emulated are consumed.
CREATE_2_COMMANDS: Dict[int, Tuple[Handler, Tuple[int, ...]]] = {
    **{op: entry for op, entry in COMMANDS.items()
       if op in protocol.CREATE_2_FIXED_ARG_BYTES or op in (protocol.SONG, protocol.STREAM,
                                                          protocol.QUERY_LIST)},
    protocol.MAX: (lambda r, a: r.start_demo(DEMO_COVER), STARTED),
    protocol.RESET: (lambda r, a: r.power_cycle(), STARTED),
    protocol.STOP: (lambda r, a: r.power_cycle(), STARTED),
    protocol.POWER: (lambda r, a: r.enter_passive(), STARTED),
    protocol.DRIVE_PWM: (_ignored, ACTUATING),
    protocol.SCHEDULING_LEDS: (_ignored, ACTUATING),
    protocol.DIGIT_LEDS_RAW: (_ignored, ACTUATING),
    protocol.DIGIT_LEDS_ASCII: (_ignored, ACTUATING),
    protocol.BUTTONS: (_ignored, STARTED),
    protocol.SCHEDULE: (_ignored, STARTED),
    protocol.SET_DAY_TIME: (_ignored, STARTED)}

_VARIABLE_LENGTH = (protocol.SONG, protocol.STREAM, protocol.QUERY_LIST, protocol.SCRIPT)


def _fixed_lengths(commands, arg_bytes) -> Dict[int, int]:
    """Total length (opcode + data) of every fixed-length command, from protocol.py."""
    lengths = {}
    for op in commands:
        if op in _VARIABLE_LENGTH:
            continue
        if op not in arg_bytes:
            raise KeyError("protocol's data byte table lacks opcode %d" % op)
        lengths[op] = 1 + arg_bytes[op]
    return lengths


_LENGTHS = _fixed_lengths(COMMANDS, protocol.FIXED_ARG_BYTES)
_CREATE_2_LENGTHS = _fixed_lengths(CREATE_2_COMMANDS, protocol.CREATE_2_FIXED_ARG_BYTES)
#: robot model name -> (commands, fixed lengths)
COMMAND_SETS = {"create_1": (COMMANDS, _LENGTHS),
                "create_2": (CREATE_2_COMMANDS, _CREATE_2_LENGTHS)}


def command_length(rx: bytearray, lengths: Optional[Dict[int, int]] = None) -> Optional[int]:
    """Bytes the command at the head of `rx` needs, None if not known yet."""
    op = rx[0]
    fixed = (_LENGTHS if lengths is None else lengths).get(op)
    if fixed is not None:
        return fixed
    if op == protocol.SONG:              # [140][song][n][note, duration] * n
        return 3 + 2 * rx[2] if len(rx) >= 3 else None
    return 2 + rx[1] if len(rx) >= 2 else None   # [op][n][n bytes]


SKIPPED = (-1, b"")
"""take_command's answer when it discarded one byte (an unknown opcode, or not Start while
the OI is off)."""


def take_command(rx: bytearray, mode: int, model: str = "create_1"
                 ) -> Optional[Tuple[int, bytes]]:
    """Cut the command at the head of the non-empty input queue `rx`: (opcode, data
    bytes), :data:`SKIPPED`, or None while the command is incomplete (`rx` untouched).
    ``model``: whose command set frames the bytes (:data:`COMMAND_SETS`)."""
    commands, lengths = COMMAND_SETS[model]
    op = rx[0]
    if (mode == OFF and op != protocol.START) or op not in commands:
        del rx[0]                            # the OI only listens for Start when off
        return SKIPPED
    need = command_length(rx, lengths)
    if need is None or len(rx) < need:
        return None                          # wait for the rest of the command
    args = bytes(rx[1:need])
    del rx[:need]
    return op, args


def execute(robot: VirtualCreate, op: int, args: bytes, model: str = "create_1") -> bool:
    """Run a command taken by take_command; False when the robot's mode does not allow it
    (then it is consumed and ignored)."""
    handler, modes = COMMAND_SETS[model][0][op]
    if robot.oi_mode not in modes:
        return False
    handler(robot, args)
    return True


def wait_events(robot: CreateState) -> Dict[int, Callable[[], bool]]:
    """Wait Event ids of the Create OI -> condition on the robot."""
    table = {
        1: robot.wheel_drop_any,
        2: lambda: robot.wheel_drop_caster,
        3: lambda: robot.wheel_drop_left,
        4: lambda: robot.wheel_drop_right,
        5: lambda: robot.bump_left or robot.bump_right,
        6: lambda: robot.bump_left,
        7: lambda: robot.bump_right,
        8: lambda: robot.virtual_wall,
        9: lambda: robot.wall,
        10: robot.cliff_any,
        11: lambda: robot.cliff_left,
        12: lambda: robot.cliff_front_left,
        13: lambda: robot.cliff_front_right,
        14: lambda: robot.cliff_right,
        15: lambda: robot.home_base,
        16: lambda: robot.button_advance,
        17: lambda: robot.button_play,
        22: lambda: robot.oi_mode == PASSIVE,
    }
    for bit in range(4):                       # 18..21: cargo bay digital inputs 0..3
        table[18 + bit] = (lambda k: lambda: bool(robot.cargo_digital_inputs >> k & 1))(bit)
    return table
