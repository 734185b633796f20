#!/usr/bin/env python3
"""Render the simulated Q24 camera's view without ROS, and time it.

    render_camera.py WORLD.yaml --pose X Y YAW [--yaw-rate W] [--seed S] [--time T]
                     [--logo NAME=PNG ...] [--raw] [-o OUT.png] [--bench N]

Writes what ``sim_camera`` would publish at that true pose (``--raw``: the rendering
without the sensor effects). ``--bench N`` renders N frames at poses along a small turn
and prints the median and best time per frame of the renderer and of the effects, on
one core (run it on an idle machine; the numbers go in docs/results/ascc_sim.md).
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import cv2
import numpy as np

from ascc_common.camera_model import PanoramicCamera
from ascc_sim.camera_effects import CameraEffects, CameraEffectsParams
from ascc_sim.camera_render import Body, CameraRenderer, load_textures
from ascc_sim.people import ScriptedPerson
from ascc_sim.world import WorldError, load_world

DEFAULT_LOGO = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..",
                            "target_follower", "templates", "ascc_logo.png")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("world")
    ap.add_argument("--pose", nargs=3, type=float, required=True, metavar=("X", "Y", "YAW"))
    ap.add_argument("--yaw-rate", type=float, default=0.0, help="[rad/s] for the blur")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--time", type=float, default=0.0, help="[s] people and drift time")
    ap.add_argument("--logo", action="append", default=[], metavar="NAME=PNG",
                    help="poster texture (default: ascc_logo from target_follower, if "
                         "found in the source tree)")
    ap.add_argument("--raw", action="store_true", help="no sensor effects")
    ap.add_argument("-o", "--output", help="write the image here (PNG)")
    ap.add_argument("--bench", type=int, default=0, metavar="N")
    args = ap.parse_args(argv)
    cv2.setNumThreads(1)
    logos = dict(item.split("=", 1) for item in args.logo)
    if not logos and os.path.isfile(DEFAULT_LOGO):
        logos = {"ascc_logo": DEFAULT_LOGO}
    try:
        world = load_world(args.world)
        textures = load_textures(logos)
    except (WorldError, ValueError) as exc:
        print("ERROR %s" % exc, file=sys.stderr)
        return 1
    cam = PanoramicCamera()
    renderer = CameraRenderer(world, cam, textures)
    effects = CameraEffects(CameraEffectsParams(), (cam.height_px, cam.width_px, 3),
                            args.seed)
    people = []
    for spec in world.people:
        st = ScriptedPerson(spec).state(args.time)
        people.append(Body(st.x, st.y, spec.radius_m, spec.height_m, spec.color))
    x, y, yaw = args.pose
    blur = cam.blur_length_px(args.yaw_rate, effects.params.exposure_s)
    img = renderer.render(x, y, yaw, people)
    if not args.raw:
        img = effects.apply(img, args.time, blur, 0)
    if args.output:
        cv2.imwrite(args.output, img)
    if args.bench > 0:
        t_render, t_fx = [], []
        for k in range(args.bench):
            t0 = time.process_time()
            frame = renderer.render(x, y, yaw + 0.05 * k, people)
            t1 = time.process_time()
            effects.apply(frame, args.time + 0.1 * k, blur, k)
            t2 = time.process_time()
            t_render.append(t1 - t0)
            t_fx.append(t2 - t1)
        print("%d x %d, %d frames (CPU time per frame): render median %.1f ms (best "
              "%.1f), effects median %.1f ms (best %.1f)"
              % (cam.width_px, cam.height_px, args.bench, 1e3 * np.median(t_render),
                 1e3 * min(t_render), 1e3 * np.median(t_fx), 1e3 * min(t_fx)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
