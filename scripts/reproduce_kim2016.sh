#!/usr/bin/env bash
# Regenerates docs/reproduction/kim2016.md and renders/kim2016/*.png from a clean build.
# The Python step runs its simulations two at a time (both cores of the machine in BENCHMARKS.md).
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$here/scripts/build.sh" mjstepper_cli mjstepper
"$here/.venv/bin/python" "$here/src/tools/python/reproduce_kim2016.py"
