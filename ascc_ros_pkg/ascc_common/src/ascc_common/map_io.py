"""map_server map files (YAML + image): the stack's one reader (`load_map`) and writer
(`save_map`). Pure Python (PyYAML, OpenCV), no ROS.

The YAML (http://wiki.ros.org/map_server#YAML_format)::

    image: office.pgm          # required; relative to the YAML's directory
    resolution: 0.05           # required [m/cell], > 0
    origin: [-1.0, 2.0, 0.0]   # required: x [m], y [m], yaw [rad] of the image's
                               # lower-left pixel
    negate: 0                  # 0 or 1 (default 0)
    occupied_thresh: 0.65      # default 0.65, within 0..1
    free_thresh: 0.196         # default 0.196, within 0..1 and below occupied_thresh
    mode: trinary              # trinary (default) | scale | raw

Pixels: 8- or 16-bit grey, or colour (the colour channels are averaged, alpha ignored);
values are scaled to 0..255. The image's top row is the map's last row (map_server flips
it), so the returned grid follows ``ascc_common.grid``: ``grid[iy, ix]``, row 0 at the
origin. Cell values, by mode (p = (255 - v) / 255, or v / 255 with ``negate: 1``):
  * trinary and scale: p > occupied_thresh -> OCCUPIED, p < free_thresh -> FREE, else
    UNKNOWN (scale's in-between probabilities are too uncertain to plan with);
  * raw: the pixel value (255 - v with negate) is the cell value, as map_server publishes
    it (int8, so 128..255 wrap to negative), then ``grid.to_trinary``.
Every problem with the files raises `MapError` naming the file and the field, e.g.
``maps/x.yaml: free_thresh: must be below occupied_thresh (0.9 >= 0.65)``; a YAML file
that cannot be opened raises OSError as usual.
"""

from __future__ import annotations

import os
from typing import Any, Dict, Optional, Sequence, Tuple

import cv2
import numpy as np
import yaml

from ascc_common.grid import FREE, OCCUPIED, UNKNOWN, GridInfo, to_trinary

MODES = ("trinary", "scale", "raw")
KEYS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode")
DEFAULTS: Dict[str, Any] = {"negate": 0, "occupied_thresh": 0.65, "free_thresh": 0.196,
                            "mode": "trinary"}
# What save_map writes for each cell value (map_server's map_saver colours).
PIXEL_FREE, PIXEL_OCCUPIED, PIXEL_UNKNOWN = 254, 0, 205


class MapError(ValueError):
    """A malformed map file. ``str()`` is one line: ``file: field: message``."""

    def __init__(self, path: str, field: str, message: str):
        super().__init__("%s: %s: %s" % (path, field, message))
        self.path = path
        self.field = field
        self.message = message


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v)


def _read_yaml(path: str) -> Any:
    with open(path, encoding="utf-8") as f:
        try:
            return yaml.safe_load(f)
        except yaml.YAMLError as e:
            mark = getattr(e, "problem_mark", None)
            where = " at line %d column %d" % (mark.line + 1, mark.column + 1) if mark else ""
            problem = getattr(e, "problem", None) or str(e).splitlines()[0]
            raise MapError(path, "(yaml)", "syntax error%s: %s" % (where, problem)) from None


def _read_meta(path: str, modes: Sequence[str]) -> Dict[str, Any]:
    """The validated YAML fields, defaults filled in."""
    doc = _read_yaml(path)
    if not isinstance(doc, dict):
        raise MapError(path, "(file)", "expected a mapping of map_server fields (%s)"
                       % ", ".join(KEYS))
    unknown = sorted(str(k) for k in doc if k not in KEYS)
    if unknown:
        raise MapError(path, unknown[0], "unknown field (known: %s)" % ", ".join(KEYS))
    for key in ("image", "resolution", "origin"):
        if key not in doc:
            raise MapError(path, key, "missing required field")
    meta = dict(DEFAULTS, **doc)
    _check_values(path, meta, modes)
    return meta


def _check_values(path: str, meta: Dict[str, Any], modes: Sequence[str]) -> None:
    if not isinstance(meta["image"], str) or not meta["image"]:
        raise MapError(path, "image", "expected a file name, got %r" % (meta["image"],))
    if not (_is_number(meta["resolution"]) and meta["resolution"] > 0.0):
        raise MapError(path, "resolution", "must be a number > 0, got %r"
                       % (meta["resolution"],))
    origin = meta["origin"]
    if not (isinstance(origin, list) and len(origin) == 3 and all(map(_is_number, origin))):
        raise MapError(path, "origin", "expected [x, y, yaw], got %r" % (origin,))
    if meta["negate"] not in (0, 1) or isinstance(meta["negate"], bool):
        raise MapError(path, "negate", "must be 0 or 1, got %r" % (meta["negate"],))
    for key in ("occupied_thresh", "free_thresh"):
        if not (_is_number(meta[key]) and 0.0 <= meta[key] <= 1.0):
            raise MapError(path, key, "must be a number within 0..1, got %r" % (meta[key],))
    if meta["free_thresh"] >= meta["occupied_thresh"]:
        raise MapError(path, "free_thresh", "must be below occupied_thresh (%g >= %g)"
                       % (meta["free_thresh"], meta["occupied_thresh"]))
    if meta["mode"] not in modes:
        raise MapError(path, "mode", "must be one of %s, got %r"
                       % (", ".join(modes), meta["mode"]))


def _read_pixels(path: str, image: str) -> np.ndarray:
    """The image as float64 grey values 0..255, top row first."""
    image_path = image if os.path.isabs(image) else os.path.join(
        os.path.dirname(os.path.abspath(path)), image)
    img = cv2.imread(image_path, cv2.IMREAD_UNCHANGED) if os.path.isfile(image_path) else None
    if img is None:
        raise MapError(path, "image", "cannot read image file %s" % image_path)
    scale = 255.0 / 65535.0 if img.dtype == np.uint16 else 1.0
    if img.ndim == 3:  # colour: average the colour channels, ignore alpha
        return img[:, :, :3].mean(axis=2) * scale
    return img.astype(np.float64) * scale


def load_map(path: str, modes: Sequence[str] = MODES) -> Tuple[np.ndarray, GridInfo]:
    """Read a map_server map into a trinary int8 grid (height, width) and its GridInfo
    (origin yaw included). ``modes``: the modes the caller accepts (others are a MapError
    on the field ``mode``)."""
    meta = _read_meta(path, modes)
    value = _read_pixels(path, meta["image"])
    if meta["negate"]:
        value = 255.0 - value
    if meta["mode"] == "raw":
        raw = np.floor(value).astype(np.uint8).view(np.int8)  # map_server's int8 cell
        grid = to_trinary(raw)[0]
    else:
        p_occ = (255.0 - value) / 255.0
        grid = np.full(value.shape, UNKNOWN, dtype=np.int8)
        grid[p_occ > meta["occupied_thresh"]] = OCCUPIED
        grid[p_occ < meta["free_thresh"]] = FREE
    grid = np.ascontiguousarray(np.flipud(grid))
    x, y, yaw = (float(v) for v in meta["origin"])
    info = GridInfo(float(meta["resolution"]), grid.shape[1], grid.shape[0], x, y, yaw)
    return grid, info


def save_map(path: str, grid: np.ndarray, info: GridInfo,
             image: Optional[str] = None, comment: str = "") -> str:
    """Write a trinary grid as map_server YAML (``path``, headed by ``# comment`` if one is
    given) + PGM (``image``, default the YAML's name with .pgm, next to it): free 254,
    occupied 0, anything else 205 (unknown), mode trinary with the default thresholds.
    Returns the image's path."""
    if grid.shape != info.shape:
        raise ValueError("grid of shape %s does not match %r" % (grid.shape, info))
    img = np.full(grid.shape, PIXEL_UNKNOWN, dtype=np.uint8)
    img[grid == FREE] = PIXEL_FREE
    img[grid == OCCUPIED] = PIXEL_OCCUPIED
    if image is None:
        image = os.path.splitext(os.path.basename(path))[0] + ".pgm"
    image_path = image if os.path.isabs(image) else os.path.join(
        os.path.dirname(os.path.abspath(path)), image)
    if not cv2.imwrite(image_path, np.flipud(img)):
        raise OSError("cannot write map image %s" % image_path)
    with open(path, "w", encoding="utf-8") as f:
        if comment:
            f.write("# %s\n" % comment)
        f.write("image: %s\nresolution: %r\norigin: [%r, %r, %r]\nnegate: 0\n"
                "occupied_thresh: %r\nfree_thresh: %r\nmode: trinary\n"
                % (image, info.resolution, info.origin_x, info.origin_y, info.origin_yaw,
                   DEFAULTS["occupied_thresh"], DEFAULTS["free_thresh"]))
    return image_path
