"""The ASCCbot's robot description (URDF) as thesis section 2.2 and fig. 2.2 describe it.

An iRobot Create (or Create 2: the diameter, height and wheel base of the model chosen,
``irobot_create_2_1.models``) carrying a four-layer plexiglass stand. Layers 1 and 2 hold
the FitPC2 (room for a second one); the two layouts of 2.2 differ on layers 3 and 4:

==============  ==========================  ==========================
layout          layer 3                     layer 4
==============  ==========================  ==========================
omnivision      Hokuyo URG-04LX (`laser`)   Mobotix Q24 (`camera`)
webcam          webcam (`camera`)           Hokuyo URG-04LX (`laser`)
==============  ==========================  ==========================

The telepresence version (chapter 4) adds a stand behind the sensors with the tablet
(the thesis's iPad) and the Kinect (`kinect`) on top. Every joint is fixed (the Create's
driver publishes ``odom -> base_link``; no joint states), so ``robot_state_publisher``
puts the whole robot on ``/tf_static``. ``base_link`` is on the floor between the wheels,
x forward, z up (the driver's and the simulator's frame); `laser` is the scan plane's
centre, `camera` the Q24's lens (x forward, z up: a panorama, ``ascc_common.camera_model``).

The thesis gives no dimensions of the stand. The layer heights are parameters whose
defaults put the sensors where the simulator and the target detector have them (laser
scan plane 0.30 m, Q24 lens 0.55 m above the floor; ``test/test_shared_settings.py``
checks the agreement): measure your robot and set them.

Pure Python (no ROS): ``urdf(params)`` is the XML, ``mounts(params)`` the sensor frames'
poses in ``base_link`` for tests and tools.
"""
from dataclasses import dataclass
from typing import Dict, List, Tuple
from xml.dom import minidom
from xml.etree import ElementTree as ET

from ascc_common.params import param
from irobot_create_2_1.models import MODELS, model

LAYOUTS = ("omnivision", "webcam")

# Device sizes [m] (boxes and cylinders for rviz; from the makers' data sheets)
FITPC2_BOX = (0.115, 0.101, 0.027)    # FitPC2: 115 x 101 x 27 mm
URG04LX_BOX = (0.050, 0.050, 0.070)   # Hokuyo URG-04LX: 50 x 50 x 70 mm
Q24_CYL = (0.060, 0.080)              # Mobotix Q24: dome radius, height
WEBCAM_BOX = (0.030, 0.080, 0.030)
KINECT_BOX = (0.070, 0.280, 0.060)    # Kinect (Xbox 360): 280 mm wide
TABLET_BOX = (0.010, 0.242, 0.186)    # iPad, standing upright, facing forward
PLATE_THICKNESS_M = 0.006             # plexiglass
POST_RADIUS_M = 0.006                 # the stand's four threaded posts


@dataclass
class DescriptionParams:
    """What selects and sizes the ASCCbot's description (``asccbot_urdf name:=value``)."""

    layout: str = param("omnivision", "which device is on layers 3 and 4 (2.2): "
                        "omnivision = laser on 3, Q24 on 4; webcam = webcam on 3, laser on 4",
                        choices=LAYOUTS)
    robot_model: str = param("create_1", "the base: create_1 | create_2 (its diameter, "
                             "height and wheel base)", choices=tuple(sorted(MODELS)))
    telepresence: bool = param(False, "add the telepresence stand (tablet and Kinect, ch. 4)")
    layer_heights_m: List[float] = param(
        [0.10, 0.17, 0.24, 0.48], "[m] height of the top of layers 1-4 above the floor",
        length=4, gt=0.0)
    stand_radius_m: float = param(0.15, "[m] radius of the plexiglass plates", gt=0.0)
    laser_x_m: float = param(0.05, "[m] the laser's x in base_link", ge=-0.2, le=0.2)
    laser_scan_height_m: float = param(
        0.06, "[m] the URG-04LX's scan plane above the plate it stands on", ge=0.0)
    camera_x_m: float = param(0.0, "[m] the camera's x in base_link", ge=-0.2, le=0.2)
    q24_lens_height_m: float = param(0.07, "[m] the Q24's lens above its plate", ge=0.0)
    webcam_lens_height_m: float = param(0.04, "[m] the webcam's lens above its plate",
                                        ge=0.0)
    tablet_height_m: float = param(0.80, "[m] the tablet's centre above the floor",
                                   gt=0.0)
    kinect_height_m: float = param(1.00, "[m] the Kinect's centre above the floor", gt=0.0)
    telepresence_stand_x_m: float = param(-0.10, "[m] x of the telepresence stand's mast",
                                          ge=-0.2, le=0.2)
    frame_prefix: str = param("", "prefix of every link name, e.g. 'robotA/' (namespaced "
                              "robots: frames robotA/base_link, robotA/laser, ...)")

    def validate(self) -> None:
        h = self.layer_heights_m
        base_top = base_dimensions(self.robot_model)[1]
        if not all(a < b for a, b in zip([base_top] + h[:-1], h)):
            raise ValueError("layer_heights_m %s: the layers must rise above the base's top "
                             "(%.3f m) in order" % (h, base_top))
        if self.telepresence and not h[3] < self.tablet_height_m < self.kinect_height_m:
            raise ValueError("tablet_height_m %.3f and kinect_height_m %.3f: the tablet "
                             "must be above layer 4 (%.3f m) and below the Kinect"
                             % (self.tablet_height_m, self.kinect_height_m, h[3]))


# Base dimensions per model, diameter and height [m]: Create 1 0.33 m (thesis 2.2; its
# manual's 13 in), height about 0.075 m; Create 2 (Create 2 OI spec: 13.39 in x 3.6 in)
_BASE = {"create_1": (0.33, 0.075), "create_2": (0.34, 0.092)}


def base_dimensions(robot_model: str) -> Tuple[float, float, float]:
    """(diameter, height, wheel base) [m] of the Create model ``robot_model``."""
    m = model(robot_model)
    diameter, height = _BASE[m.name]
    return diameter, height, m.wheel_base_m


def mounts(p: DescriptionParams) -> Dict[str, Tuple[float, float, float, float]]:
    """Sensor frames in ``base_link``: name -> (x, y, z, yaw) [m, rad]."""
    h = p.layer_heights_m
    if p.layout == "omnivision":
        laser_z, camera_z = h[2] + p.laser_scan_height_m, h[3] + p.q24_lens_height_m
    else:
        laser_z, camera_z = h[3] + p.laser_scan_height_m, h[2] + p.webcam_lens_height_m
    out = {"laser": (p.laser_x_m, 0.0, laser_z, 0.0),
           "camera": (p.camera_x_m, 0.0, camera_z, 0.0)}
    if p.telepresence:
        out["kinect"] = (p.telepresence_stand_x_m, 0.0, p.kinect_height_m, 0.0)
    return out


class _Builder:
    def __init__(self, prefix: str):
        self.prefix = prefix
        self.root = ET.Element("robot", name="asccbot")
        for name, rgba in (("create_grey", "0.35 0.35 0.38 1"), ("plexiglass", "0.8 0.9 1 0.35"),
                           ("black", "0.08 0.08 0.08 1"), ("white", "0.92 0.92 0.92 1"),
                           ("metal", "0.6 0.6 0.62 1")):
            ET.SubElement(ET.SubElement(self.root, "material", name=name), "color", rgba=rgba)

    def link(self, name: str, shapes=()) -> None:
        """A link with visuals: (geometry tag, attributes, xyz, material)."""
        el = ET.SubElement(self.root, "link", name=self.prefix + name)
        for tag, attrs, xyz, material in shapes:
            vis = ET.SubElement(el, "visual")
            ET.SubElement(vis, "origin", xyz=_xyz(xyz), rpy="0 0 0")
            ET.SubElement(ET.SubElement(vis, "geometry"), tag, **attrs)
            ET.SubElement(vis, "material", name=material)

    def fixed(self, parent: str, child: str, xyz, yaw: float = 0.0) -> None:
        j = ET.SubElement(self.root, "joint", name="%s%s_joint" % (self.prefix, child),
                          type="fixed")
        ET.SubElement(j, "parent", link=self.prefix + parent)
        ET.SubElement(j, "child", link=self.prefix + child)
        ET.SubElement(j, "origin", xyz=_xyz(xyz), rpy="0 0 %.6g" % yaw)


def _xyz(v) -> str:
    return " ".join("%.6g" % (c + 0.0) for c in v)


def _box(size):
    return {"size": _xyz(size)}


def _cyl(radius, length):
    return {"radius": "%.6g" % radius, "length": "%.6g" % length}


def urdf(p: DescriptionParams) -> str:
    """The URDF (XML text) of the ASCCbot described by ``p``."""
    diameter, base_h, wheel_base = base_dimensions(p.robot_model)
    b = _Builder(p.frame_prefix)
    clearance = 0.01  # the Create's body above the floor
    b.link("base_link", [("cylinder", _cyl(diameter / 2, base_h - clearance),
                          (0, 0, clearance + (base_h - clearance) / 2), "create_grey")])
    wheel_r = 0.036
    for side, y in (("left", wheel_base / 2), ("right", -wheel_base / 2)):
        b.link(side + "_wheel", [("box", _box((2 * wheel_r, 0.02, 2 * wheel_r)), (0, 0, 0),
                                  "black")])
        b.fixed("base_link", side + "_wheel", (0, y, wheel_r))
    h = p.layer_heights_m
    r = p.stand_radius_m
    # the four plates on posts that stand on the Create's top
    post = r * 0.8
    posts = [("cylinder", _cyl(POST_RADIUS_M, h[3] - base_h),
              (x, y, (base_h + h[3]) / 2), "metal")
             for x, y in ((post, 0), (-post, 0), (0, post), (0, -post))]
    b.link("stand", posts)
    b.fixed("base_link", "stand", (0, 0, 0))
    for i, top in enumerate(h, start=1):
        b.link("layer_%d" % i, [("cylinder", _cyl(r, PLATE_THICKNESS_M),
                                 (0, 0, -PLATE_THICKNESS_M / 2), "plexiglass")])
        b.fixed("stand", "layer_%d" % i, (0, 0, top))
    b.link("fitpc2", [("box", _box(FITPC2_BOX), (0, 0, FITPC2_BOX[2] / 2), "black")])
    b.fixed("layer_1", "fitpc2", (0, 0, 0))
    m = mounts(p)
    laser_layer, camera_layer = ("layer_3", "layer_4") if p.layout == "omnivision" else (
        "layer_4", "layer_3")
    lx, _, lz, lyaw = m["laser"]
    b.link("laser", [("box", _box(URG04LX_BOX),
                      (0, 0, URG04LX_BOX[2] / 2 - p.laser_scan_height_m), "black")])
    b.fixed(laser_layer, "laser", (lx, 0, lz - h[int(laser_layer[-1]) - 1]), lyaw)
    cx, _, cz, cyaw = m["camera"]
    cam_base = h[int(camera_layer[-1]) - 1]
    if p.layout == "omnivision":
        shape = ("cylinder", _cyl(*Q24_CYL), (0, 0, Q24_CYL[1] / 2 - p.q24_lens_height_m),
                 "white")
    else:
        shape = ("box", _box(WEBCAM_BOX), (0, 0, WEBCAM_BOX[2] / 2 - p.webcam_lens_height_m),
                 "black")
    b.link("camera", [shape])
    b.fixed(camera_layer, "camera", (cx, 0, cz - cam_base), cyaw)
    if p.telepresence:
        kx, _, kz, kyaw = m["kinect"]
        b.link("telepresence_stand", [("cylinder", _cyl(0.012, kz - h[3]),
                                       (0, 0, (kz - h[3]) / 2), "metal")])
        b.fixed("layer_4", "telepresence_stand", (kx, 0, 0))
        b.link("tablet", [("box", _box(TABLET_BOX), (0, 0, 0), "black")])
        b.fixed("telepresence_stand", "tablet",
                (0.02 + TABLET_BOX[0] / 2, 0, p.tablet_height_m - h[3]))
        b.link("kinect", [("box", _box(KINECT_BOX), (0, 0, 0), "black")])
        b.fixed("telepresence_stand", "kinect", (0, 0, kz - h[3]), kyaw)
    return minidom.parseString(ET.tostring(b.root)).toprettyxml(indent="  ")
