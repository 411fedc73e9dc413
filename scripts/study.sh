#!/usr/bin/env bash
# The main job: the Tsui rigid-load ramp 0 → 200 r/min in 0.8 s (Tsui 2009 Fig. 7 conditions),
# current-controlled microstepping at 1.9 A, no damping. Writes logs/tsui_rigid_ramp.csv and prints
# a summary.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$here/scripts/build.sh" mjstepper_cli mjstepper
cd "$here"
./build/mjstepper info models/tsui_rigid.xml
./build/mjstepper run models/tsui_rigid.xml --duration 0.8 \
  --ctrl 'shaft=ramp(0rpm,200rpm,0.8s)' --log logs/tsui_rigid_ramp.csv
