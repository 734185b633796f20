"""detect_targets: the target detector on image files, one JSON line per image.

    rosrun target_follower detect_targets --kind cone|shirt|logo [--template FILE.png]
        [--config FILE.yaml] [--blur-px N] IMAGE...

Prints, for every IMAGE in order, ``{"image": PATH, "detections": [{"kind": K, "u": px,
"v": px, "bbox": [x, y, w, h], "area_px": N, "score": S}]}`` (best first; an empty list
when there is none). The colour kinds read their thresholds from the package's
``config/<kind>.yaml`` (``--config`` another); the logo is matched to
``templates/ascc_logo.png`` (``--template`` another), ``--blur-px`` the row blur of the
images (0: still). An image that cannot be read is reported on stderr by its path and
skipped (no JSON line); the others are still processed; the exit status is then 2. Exit
status 3: the template or the config is unusable (nothing processed). 0: all images read.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
from typing import List, Optional

import cv2
import yaml

from ascc_common.params import ParamError, from_params, tree_getter

from .color_detector import COLOR_KINDS, KINDS, ColorDetector, ColorParams
from .logo_detector import LogoDetector, LogoParams, load_template

PKG_DIR = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DEFAULT_TEMPLATE = os.path.join(PKG_DIR, "templates", "ascc_logo.png")


def config_path(kind: str) -> str:
    """The package's default parameter file of ``kind``."""
    return os.path.join(PKG_DIR, "config", "%s.yaml" % kind)


def load_config(path: str) -> dict:
    with open(path) as f:
        tree = yaml.safe_load(f) or {}
    if not isinstance(tree, dict):
        raise ValueError("%s: expected a mapping of parameters" % path)
    return tree


def make_detector(kind: str, template: Optional[str] = None, config: Optional[str] = None,
                  strip_height_px: int = 0):
    """A detector of ``kind`` with the package's (or the given) config and template;
    ValueError / OSError / ParamError naming what is wrong."""
    if kind in COLOR_KINDS:
        path = config or config_path(kind)
        params = from_params(ColorParams, tree_getter(load_config(path)))
        return ColorDetector(kind, params, strip_height_px)
    tree = load_config(config) if config else {}
    return LogoDetector(load_template(template or DEFAULT_TEMPLATE),
                        from_params(LogoParams, tree_getter(tree)), strip_height_px)


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="detect_targets", description=__doc__.split("\n\n")[0])
    ap.add_argument("--kind", choices=KINDS, required=True)
    ap.add_argument("--template", help="logo template image (default: the package's)")
    ap.add_argument("--config", help="parameter YAML (default: config/<kind>.yaml)")
    ap.add_argument("--blur-px", type=float, default=0.0,
                    help="horizontal motion blur of the images [px] (logo)")
    ap.add_argument("--strip-height-px", type=int, default=-1,
                    help="panorama strip height [px] (-1: half the image height, a double "
                         "panorama; 0: one strip)")
    ap.add_argument("images", nargs="+", metavar="IMAGE")
    return ap


def main(argv: Optional[List[str]] = None) -> int:
    args = _parser().parse_args(argv)
    try:
        detector = make_detector(args.kind, args.template, args.config)
    except (OSError, ValueError, ParamError, yaml.YAMLError) as exc:
        print("detect_targets: error: %s" % exc, file=sys.stderr)
        return 3
    status = 0
    for path in args.images:
        img = cv2.imread(path, cv2.IMREAD_COLOR)
        if img is None or img.size == 0:
            print("detect_targets: error: cannot read image %s" % path, file=sys.stderr)
            status = 2
            continue
        detector.strip_height_px = (img.shape[0] // 2 if args.strip_height_px < 0
                                    else args.strip_height_px)
        if isinstance(detector, ColorDetector):
            blobs = detector.detect(img)
        else:
            blobs = detector.detect(img, args.blur_px)
        print(json.dumps({"image": path, "detections": [b.to_json() for b in blobs]}),
              flush=True)
    return status
