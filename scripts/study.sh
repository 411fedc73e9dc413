#!/usr/bin/env bash
# The main job, the default study: the Tsui rigid-load ramp 0 → 200 r/min in 0.8 s (Tsui 2009
# Fig. 7 conditions) on two identical motors side by side (models/tsui_pair.xml), one undamped and
# one with all three detent harmonics compensated (T(13)). Writes
#   logs/study_ramp.csv                  every signal of both motors, every 50 µs step
#   renders/study_ramp.mp4               side-by-side video, 10× slow motion, with overlays
#   renders/study_velocity_error.png     both velocity errors against commanded speed
#   renders/study_ramp.png               both runs' signals against time
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
./build/mjstepper info models/tsui_pair.xml
./build/mjstepper run models/tsui_pair.xml --duration 0.8 \
  --ctrl 'undamped=ramp(0rpm,200rpm,0.8s)' --ctrl 'damped=ramp(0rpm,200rpm,0.8s)' \
  --log logs/study_ramp.csv --plot renders/study_ramp.png \
  --render renders/study_ramp.mp4 --camera front --size 1280x720 --fps 30 --playback 0.1
./build/mjstepper plot logs/study_ramp.csv --versus-speed --out renders/study_velocity_error.png \
  --title "Tsui ramp 0-200 r/min: velocity error, undamped vs all three harmonics damped"
.venv/bin/python src/tools/python/study_arm.py
.venv/bin/python src/tools/python/study_drivers.py
.venv/bin/python src/tools/python/study_arm6.py
.venv/bin/python src/tools/python/study_parol6.py
echo "study done in ${SECONDS} s (after the build)"
