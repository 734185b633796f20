"""run_if_installed's messages and checks, and the udev rules."""
import pytest

from asccbot_bringup import packages, udev


def test_missing_packages_are_named_with_the_noetic_package_and_the_hint(capsys):
    assert packages.missing_packages(["roslaunch", "no_such_pkg_xyz"]) == ["no_such_pkg_xyz"]
    assert packages.main(["--check", "--what", "the mapper", "--hint", "use_stand_ins:=true",
                          "roslaunch", "no_such_pkg_xyz", "__name:=check"]) == 1
    err = capsys.readouterr().err
    assert "no_such_pkg_xyz" in err and "ros-noetic-no-such-pkg-xyz" in err
    assert "use_stand_ins:=true" in err and "the mapper" in err and "roslaunch," not in err


def test_run_mode_refuses_a_missing_package_or_executable(capsys):
    assert packages.main(["--hint", "laser:=false", "no_such_pkg_xyz", "node"]) == 1
    assert "laser:=false" in capsys.readouterr().err
    assert packages.main(["roslaunch", "no_such_executable_xyz", "__name:=n"]) == 1
    assert "no_such_executable_xyz" in capsys.readouterr().err
    assert packages.main(["roslaunch"]) == 2  # no executable given


def test_udev_rules_name_both_devices_by_usb_id():
    text = udev.rules(udev.CREATE_IDS + [udev.parse_id("1A86:7523")], create_serial="A1B2")
    lines = [ln for ln in text.splitlines() if not ln.startswith("#")]
    assert len(lines) == len(udev.CREATE_IDS) + 1 + len(udev.HOKUYO_IDS)
    hokuyo = [ln for ln in lines if 'SYMLINK+="hokuyo"' in ln]
    assert hokuyo == ['SUBSYSTEM=="tty", ATTRS{idVendor}=="15d1", ATTRS{idProduct}=="0000", '
                      'SYMLINK+="hokuyo", GROUP="dialout", MODE="0660"']
    create = [ln for ln in lines if 'SYMLINK+="create"' in ln]
    assert len(create) == 4 and all('ATTRS{serial}=="A1B2"' in ln for ln in create)
    assert any('"1a86"' in ln and '"7523"' in ln for ln in create)
    with pytest.raises(ValueError, match="VVVV:PPPP"):
        udev.parse_id("1a86-7523")
