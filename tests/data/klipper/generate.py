#!/usr/bin/env python3
"""Reference numbers from Klipper itself, for tests/core/klipper_shaper_test.cc (issue 31).

Run once outside the build, with a Klipper checkout and numpy; Klipper is GPLv3 and is only run
here, as an outside program: nothing of it is copied into this project. See README.md beside.

  python3 generate.py KLIPPER_CHECKOUT

writes, next to this file:
  shapers.csv    Klipper's shapers (extras/shaper_defs.py, init_shaper) for every type at
                 frequencies 20-150 Hz and damping ratios 0-0.2: each impulse's amplitude
                 (divided by their sum, as Klipper's kinematics and its calibration use them) and
                 time in s;
  smoothing.csv  Klipper's smoothing (ShaperCalibrate._get_shaper_smoothing) at 5000 mm/s² and its
                 max_accel (find_shaper_max_accel), both with square_corner_velocity 5 mm/s, for
                 each type at damping 0.1 (Klipper's default) and the same frequencies.
"""
import math
import os
import sys

FREQUENCIES = [20.0, 27.3, 35.0, 42.5, 50.0, 61.8, 75.0, 90.0, 110.0, 130.0, 150.0]  # Hz
DAMPINGS = [0.0, 0.05, 0.1, 0.15, 0.2]
TYPES = ["zv", "mzv", "zvd", "ei", "2hump_ei", "3hump_ei"]
SCV = 5.0  # mm/s


def main(klipper):
    sys.path.insert(0, os.path.join(klipper, "klippy"))
    from extras import shaper_calibrate, shaper_defs  # noqa: E402  Klipper, run as a program

    here = os.path.dirname(os.path.abspath(__file__))
    with open(os.path.join(here, "shapers.csv"), "w", encoding="utf-8") as out:
        out.write("type,frequency_hz,damping,impulse,amplitude,time_s\n")
        for name in TYPES:
            for f in FREQUENCIES:
                for zeta in DAMPINGS:
                    a, t = shaper_defs.init_shaper(name, f, zeta)
                    total = sum(a)
                    for i, (ai, ti) in enumerate(zip(a, t)):
                        out.write(f"{name},{f},{zeta},{i},{ai / total:.12g},{ti:.12g}\n")
    helper = shaper_calibrate.ShaperCalibrate(printer=None)
    with open(os.path.join(here, "smoothing.csv"), "w", encoding="utf-8") as out:
        out.write("type,frequency_hz,damping,smoothing_mm_at_5000,max_accel_mm_s2\n")
        for name in TYPES:
            for f in FREQUENCIES:
                shaper = shaper_defs.init_shaper(name, f, shaper_defs.DEFAULT_DAMPING_RATIO)
                smoothing = helper._get_shaper_smoothing(shaper, accel=5000, scv=SCV)
                max_accel = helper.find_shaper_max_accel(shaper, SCV)
                out.write(f"{name},{f},{shaper_defs.DEFAULT_DAMPING_RATIO},{smoothing:.12g},"
                          f"{max_accel:.12g}\n")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
