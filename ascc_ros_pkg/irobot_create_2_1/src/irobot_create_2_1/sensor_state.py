"""Turn decoded Open Interface packets into the fields of Brown's SensorPacket message
and into SI quantities (metres, radians, volts, amperes, coulombs, degC)."""
import math
from typing import Dict, Mapping

from . import protocol as oi

# Charging state (packet 21) names, OI spec order.
CHARGING_STATES = ("not charging", "reconditioning charging", "full charging",
                   "trickle charging", "waiting", "charging fault condition")

#: Packets whose changes the driver publishes at once (not only at ``~sensor_rate_hz``):
#: bumps and wheel drops (7), cliffs (9..12), virtual wall (13), buttons (18), charging
#: sources (34), light bumper (45, Create 2). Not wall (8): it flickers along a wall.
EVENT_PACKETS = (7, 9, 10, 11, 12, 13, 18, 34, 45)


def brown_fields(values: Mapping[int, int]) -> Dict[str, object]:
    """Fields of irobot_create_2_1/SensorPacket (Brown's names and raw units) from the
    packets present in ``values``; absent packets are left out."""
    out: Dict[str, object] = {}
    get = values.get
    if 7 in values:
        b = values[7]
        out.update(bumpRight=bool(b & oi.BUMP_RIGHT), bumpLeft=bool(b & oi.BUMP_LEFT),
                   wheeldropRight=bool(b & oi.WHEELDROP_RIGHT),
                   wheeldropLeft=bool(b & oi.WHEELDROP_LEFT),
                   wheeldropCaster=bool(b & oi.WHEELDROP_CASTER))
    simple = (
        (8, "wall", bool), (9, "cliffLeft", bool), (10, "cliffFronLeft", bool),
        (11, "cliffFrontRight", bool), (12, "cliffRight", bool), (13, "virtualWall", bool),
        (17, "infraredByte", int), (19, "distance", int), (20, "angle", int),
        (21, "chargingState", int), (22, "voltage", int), (23, "current", int),
        (24, "batteryTemperature", int), (25, "batteryCharge", int),
        (26, "batteryCapacity", int), (27, "wallSignal", int), (28, "cliffLeftSignal", int),
        (29, "cliffFrontLeftSignal", int), (30, "cliffFrontRightSignal", int),
        (31, "cliffRightSignal", int), (36, "songNumber", int), (37, "songPlaying", int),
    )
    for pid, name, kind in simple:
        if pid in values:
            out[name] = kind(values[pid])
    if 18 in values:
        out.update(play=bool(get(18) & oi.BUTTON_PLAY),
                   advance=bool(get(18) & oi.BUTTON_ADVANCE))
    if 34 in values:
        out.update(internalCharger=bool(get(34) & oi.SOURCE_INTERNAL_CHARGER),
                   homeBase=bool(get(34) & oi.SOURCE_HOME_BASE))
    return out


def increments_si(values: Mapping[int, int]):
    """(distance [m], angle [rad]) since the previous read; zeros when absent."""
    return values.get(19, 0) / 1000.0, math.radians(values.get(20, 0))


def battery_si(values: Mapping[int, int]) -> Dict[str, float]:
    """Battery in SI: voltage [V], current [A] (negative = discharging), temperature [degC],
    charge and capacity [Ah], percentage [0..1] (NaN when the capacity is unknown)."""
    capacity_ah = values.get(26, 0) / 1000.0
    charge_ah = values.get(25, 0) / 1000.0
    return {
        "voltage_v": values.get(22, 0) / 1000.0,
        "current_a": values.get(23, 0) / 1000.0,
        "temperature_c": float(values.get(24, 0)),
        "charge_ah": charge_ah,
        "capacity_ah": capacity_ah,
        "percentage": charge_ah / capacity_ah if capacity_ah > 0 else float("nan"),
        "charging_state": values.get(21, 0),
    }


def hazards(values: Mapping[int, int]) -> Dict[str, bool]:
    """Bumper, cliff and wheel-drop flags."""
    b = values.get(7, 0)
    return {
        "bump_left": bool(b & oi.BUMP_LEFT), "bump_right": bool(b & oi.BUMP_RIGHT),
        "wheeldrop_left": bool(b & oi.WHEELDROP_LEFT),
        "wheeldrop_right": bool(b & oi.WHEELDROP_RIGHT),
        "wheeldrop_caster": bool(b & oi.WHEELDROP_CASTER),
        "cliff_left": bool(values.get(9, 0)), "cliff_front_left": bool(values.get(10, 0)),
        "cliff_front_right": bool(values.get(11, 0)), "cliff_right": bool(values.get(12, 0)),
        "wall": bool(values.get(8, 0)), "virtual_wall": bool(values.get(13, 0)),
    }


def light_bumper(values: Mapping[int, int]) -> Dict[str, object]:
    """Create 2: fields of irobot_create_2_1/LightBumper from packets 45..51 (empty when
    absent): one bool per sensor (packet 45's bits) and the six raw signals."""
    if 45 not in values:
        return {}
    bits = values[45]
    out: Dict[str, object] = {name: bool(bits >> i & 1)
                              for i, name in enumerate(oi.LIGHT_BUMPERS)}
    out["signals"] = [values.get(46 + i, 0) for i in range(len(oi.LIGHT_BUMPERS))]
    return out


def motors(values: Mapping[int, int]) -> Dict[str, object]:
    """Create 2: motor currents [A] (packets 54..57) and the stasis flags (58); empty when
    absent."""
    if 58 not in values:
        return {}
    names = ("left_wheel_a", "right_wheel_a", "main_brush_a", "side_brush_a")
    out: Dict[str, object] = {n: values.get(54 + i, 0) / 1000.0 for i, n in enumerate(names)}
    out["stasis_toggling"] = bool(values[58] & oi.STASIS_TOGGLING)
    out["stasis_disabled"] = bool(values[58] & oi.STASIS_DISABLED)
    return out
