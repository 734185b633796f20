#!/usr/bin/env python3
"""Draw the project's own logo, ``templates/ascc_logo.png`` (the ASCCbot's "high level"
target, thesis 2.4, in place of the OSU logo the thesis used, which we do not copy).

The design is deliberately rich in corners and contrast at several scales (a robot on a
disc, a lettering band, an asymmetric chevron row) and not symmetric, so that local
features (SIFT/ORB) find many distinctive, unambiguous points on it. No orange: the
colour targets (cone, shirt) are orange, and a poster must not look like one.

    python3 scripts/make_logo.py [OUT.png]
"""
import os
import sys

import cv2
import numpy as np

NAVY = (90, 40, 20)  # BGR
TEAL = (150, 140, 0)
WHITE = (255, 255, 255)
YELLOW = (40, 210, 250)


def draw_logo(size_px: int = 480) -> np.ndarray:
    s = size_px / 480.0
    img = np.full((int(640 * s), size_px, 3), 255, np.uint8)

    def p(x, y):
        return int(round(x * s)), int(round(y * s))

    cv2.rectangle(img, p(8, 8), p(472, 632), NAVY, max(1, int(10 * s)))
    cv2.circle(img, p(240, 215), int(170 * s), NAVY, -1)
    # the robot: body, head, eyes, antenna, wheels
    cv2.rectangle(img, p(150, 200), p(330, 330), TEAL, -1)
    cv2.rectangle(img, p(180, 110), p(300, 195), TEAL, -1)
    cv2.circle(img, p(215, 150), int(18 * s), WHITE, -1)
    cv2.circle(img, p(270, 150), int(12 * s), WHITE, -1)
    cv2.line(img, p(240, 110), p(275, 60), YELLOW, max(1, int(8 * s)))
    cv2.circle(img, p(275, 60), int(14 * s), YELLOW, -1)
    cv2.circle(img, p(175, 345), int(26 * s), WHITE, -1)
    cv2.circle(img, p(305, 345), int(26 * s), WHITE, -1)
    pts = np.array([p(170, 230), p(230, 230), p(200, 300)], np.int32)
    cv2.fillPoly(img, [pts], NAVY)
    cv2.rectangle(img, p(250, 240), p(310, 260), WHITE, -1)
    cv2.rectangle(img, p(250, 280), p(290, 300), YELLOW, -1)
    # lettering band
    cv2.rectangle(img, p(30, 400), p(450, 500), TEAL, -1)
    cv2.putText(img, "ASCC", p(60, 482), cv2.FONT_HERSHEY_DUPLEX, 3.2 * s, NAVY,
                max(1, int(9 * s)), cv2.LINE_AA)
    # an asymmetric row of chevrons and squares
    x = 40
    for k in range(7):
        if k % 3 == 2:
            cv2.rectangle(img, p(x, 540), p(x + 40, 600), NAVY, -1)
        else:
            tri = np.array([p(x, 600), p(x + 25, 530 + 10 * k), p(x + 50, 600)], np.int32)
            cv2.fillPoly(img, [tri], NAVY if k % 2 else TEAL)
        x += 58
    return img


def main() -> int:
    here = os.path.dirname(os.path.abspath(__file__))
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "..", "templates",
                                                              "ascc_logo.png")
    if not cv2.imwrite(out, draw_logo()):
        print("make_logo: cannot write %s" % out, file=sys.stderr)
        return 1
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
