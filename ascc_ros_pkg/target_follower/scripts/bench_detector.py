#!/usr/bin/env python3
"""Speed and detection rate of the target detectors on synthetic 1024 x 768 panoramas.

    rosrun target_follower bench_detector.py [--frames N] [--threads 1] [--heldout]

Speed: frames per second of ``detect`` (decoded BGR frame in, detections out; JPEG
decoding excluded and reported apart) per kind, OpenCV limited to ``--threads`` threads
(1: one core). Rates: per kind, the share of target scenes whose best detection is within
2 deg of the true bearing, and the false detections per 1000 target-free scenes, for still
frames and for the row blur of 0.26 / 0.52 / 0.87 rad/s x 0.1 s exposure (the logo with its
blur compensation, and without it for comparison). ``--heldout`` uses the held-out seeds
(never used while tuning; tuning used seeds < 10000).
"""
import argparse
import math
import platform
import time

import cv2
import numpy as np

from ascc_common.camera_model import PanoramicCamera
from target_follower import synthetic as S
from target_follower.cli import DEFAULT_TEMPLATE, make_detector
from target_follower.logo_detector import load_template

RATES = (0.0, 0.26, 0.52, 0.87)  # [rad/s], thesis Table 2.1
EXPOSURE_S = 0.1
HELDOUT_SEED0 = 100000


def fps(fn, frames, n):
    fn(frames[0])
    t0 = time.perf_counter()
    for i in range(n):
        fn(frames[i % len(frames)])
    return n / (time.perf_counter() - t0)


def rates(kind, det, cam, template, seed0, n, blur, compensate):
    hits = fps_ = 0
    for i in range(n):
        sc = S.random_scene(kind, seed0 + i, cam, template=template, blur_px=blur,
                            jpeg_quality=80)
        neg = S.random_scene(None, seed0 + 50000 + i, cam, blur_px=blur, jpeg_quality=80)
        args = (blur if compensate else 0.0,) if kind == "logo" else ()
        found = det.detect(sc.image, *args)
        if found:
            b, _ = cam.pixel_to_ray(found[0].u, found[0].v)
            err = math.remainder(float(b) - sc.targets[0].bearing_rad, 2 * math.pi)
            hits += abs(math.degrees(err)) <= 2.0
        fps_ += len(det.detect(neg.image, *args))
    return 100.0 * hits / n, 1000.0 * fps_ / n


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=100, help="scenes per cell (100)")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--heldout", action="store_true")
    args = ap.parse_args()
    cv2.setNumThreads(args.threads)
    cam = PanoramicCamera()
    template = load_template(DEFAULT_TEMPLATE)
    seed0 = HELDOUT_SEED0 if args.heldout else 0
    print("machine: %s, %s, Python %s, OpenCV %s, %d OpenCV thread(s)"
          % (platform.node(), platform.processor() or platform.machine(),
             platform.python_version(), cv2.__version__, args.threads))
    frames = [S.random_scene(k, seed0 + i, cam, template=template).image
              for i, k in enumerate(("cone", "shirt", "logo", None))]
    jpegs = [cv2.imencode(".jpg", f, [cv2.IMWRITE_JPEG_QUALITY, 80])[1] for f in frames]
    print("jpeg decode 1024x768: %.0f fps"
          % fps(lambda b: cv2.imdecode(b, cv2.IMREAD_COLOR), jpegs, 100))
    for kind in ("cone", "shirt", "logo"):
        det = make_detector(kind, strip_height_px=cam.strip_height_px)
        n = 300 if kind != "logo" else 60
        print("%-5s speed: %.0f fps" % (kind, fps(det.detect, frames, n)))
    print("rates over %d scenes per cell (%s seeds):" % (args.frames,
                                                       "held-out" if args.heldout else "tuning"))
    print("kind  rad/s  blur_px  detected_%  false_per_1000")
    for kind in ("cone", "shirt", "logo"):
        det = make_detector(kind, strip_height_px=cam.strip_height_px)
        for rate in RATES:
            blur = cam.blur_length_px(rate, EXPOSURE_S)
            for comp in ((True, False) if kind == "logo" and rate > 0 else (True,)):
                hit, fp = rates(kind, det, cam, template, seed0 + 1000 * int(rate * 100),
                                args.frames, blur, comp)
                print("%-5s %5.2f %8.1f %10.1f %15.1f%s" % (
                    kind, rate, blur, hit, fp, "" if comp else "  (no blur compensation)"))
    return 0


if __name__ == "__main__":
    np.seterr(all="ignore")
    raise SystemExit(main())
