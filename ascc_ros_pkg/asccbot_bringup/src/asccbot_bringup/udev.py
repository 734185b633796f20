"""udev rules giving the ASCCbot's USB devices stable names: ``/dev/create`` (the Create's
USB-serial cable) and ``/dev/hokuyo`` (the URG-04LX, a USB CDC-ACM device), matched by USB
vendor and product id. ``scripts/install_udev_rules`` writes them (README, "On a robot").

Known ids (``lsusb`` shows yours; ``--create-id VVVV:PPPP`` adds another):

- Hokuyo URG-04LX: 15d1:0000
- Create 2's iRobot cable (FTDI FT231X): 0403:6015
- Create 1 with an FTDI FT232R USB-serial adapter: 0403:6001; with a Prolific PL2303: 067b:2303

The FTDI and Prolific ids are generic USB-serial chips: if the robot has another adapter of
the same chip, give the cable's serial number (``--create-serial``, from
``udevadm info -a -n /dev/ttyUSB0 | grep serial``) so that only it becomes /dev/create.
Pure Python (no ROS).
"""
import re
from typing import List, Optional, Sequence, Tuple

HOKUYO_IDS = [("15d1", "0000")]
CREATE_IDS = [("0403", "6015"), ("0403", "6001"), ("067b", "2303")]
RULES_PATH = "/etc/udev/rules.d/99-asccbot.rules"


def parse_id(text: str) -> Tuple[str, str]:
    """'VVVV:PPPP' (hex, as lsusb prints it) -> (vendor, product); ValueError otherwise."""
    found = re.fullmatch(r"([0-9a-fA-F]{4}):([0-9a-fA-F]{4})", text.strip())
    if not found:
        raise ValueError("USB id %r is not VVVV:PPPP (hex, as lsusb prints it)" % text)
    return found.group(1).lower(), found.group(2).lower()


def rules(create_ids: Sequence[Tuple[str, str]] = CREATE_IDS,
          hokuyo_ids: Sequence[Tuple[str, str]] = HOKUYO_IDS,
          create_serial: Optional[str] = None, group: str = "dialout") -> str:
    """The rules file's text: one line per (device, id), readable and writable by
    ``group`` (add the robot's user to it: ``sudo adduser $USER dialout``)."""
    lines: List[str] = ["# ASCCbot: stable device names (asccbot_bringup/scripts/"
                        "install_udev_rules)"]
    serial = ', ATTRS{serial}=="%s"' % create_serial if create_serial else ""
    for name, ids, extra in (("create", create_ids, serial), ("hokuyo", hokuyo_ids, "")):
        for vendor, product in ids:
            lines.append('SUBSYSTEM=="tty", ATTRS{idVendor}=="%s", ATTRS{idProduct}=="%s"%s, '
                         'SYMLINK+="%s", GROUP="%s", MODE="0660"'
                         % (vendor, product, extra, name, group))
    return "\n".join(lines) + "\n"
