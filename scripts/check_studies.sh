#!/usr/bin/env bash
# Checks that every committed study and reproduction page, figure and video is what its script
# writes now (issue 32, item 2): builds, then runs every study script in a scratch copy of the
# tracked tree (tests/python/study_check.py) and fails naming each tracked file that changed. Run it
# after changing anything a study measures, and commit what the scripts write; ctest runs the
# quickest one (Studies.ArmStudyIsWhatItsScriptWrites). About 7 minutes on 2 cores.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$here/scripts/build.sh" mjstepper_cli mjstepper
cd "$here"
scripts=()
for name in study_ramp study_arm study_drivers study_arm6 study_parol6 study_printer \
            reproduce_tsui2009 reproduce_kim2016; do
  scripts+=("src/tools/python/$name.py")
done
.venv/bin/python tests/python/study_check.py "$here" "${scripts[@]}"
