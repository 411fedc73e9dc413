#!/usr/bin/env bash
# The main job, the default study, after the build: src/tools/python/study_ramp.py (the Tsui
# rigid-load ramp 0 → 200 r/min in 0.8 s on two identical motors side by side, models/tsui_pair.xml,
# one undamped and one with all three detent harmonics compensated: logs/study_ramp.csv,
# renders/study_ramp.mp4, renders/study_velocity_error.png, renders/study_ramp.png),
# then the robot-arm joint study (models/arm3.xml: a pick move through the shoulder's resonance,
# undamped and damped), which writes docs/studies/arm.md, renders/arm/velocity_error.png and
# renders/arm/arm.mp4; then the drivers study (models/belt_axis.xml on a catalogue NEMA 17 under
# Tsui's PI drive, SpreadCycle, StealthChop and an ideal current source), which writes
# docs/studies/drivers.md, renders/drivers/*.png and renders/drivers/belt_axis.mp4; then the 6-DOF
# arm sizing study (models/arm6.xml: a pick-and-place cycle sized with two motors per joint), which
# writes docs/studies/arm6.md, renders/arm6/*.png, *.csv and renders/arm6/pick_place_smaller.mp4;
# then the real PAROL6 study (models/parol6.xml: sizing, heat with and without IHOLD, the payload
# at which each joint first slips, settled and aligned), which writes docs/studies/parol6.md and
# renders/parol6/; and prints a summary. See renders/README.md.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$here/scripts/build.sh" mjstepper_cli mjstepper
cd "$here"
SECONDS=0
.venv/bin/python src/tools/python/study_ramp.py
.venv/bin/python src/tools/python/study_arm.py
.venv/bin/python src/tools/python/study_drivers.py
.venv/bin/python src/tools/python/study_arm6.py
.venv/bin/python src/tools/python/study_parol6.py
echo "study done in ${SECONDS} s (after the build)"
