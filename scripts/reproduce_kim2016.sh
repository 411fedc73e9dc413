#!/usr/bin/env bash
# Regenerates docs/reproduction/kim2016.md and renders/kim2016/*.png from a clean build.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$here/scripts/build.sh" mjstepper_cli mjstepper
"$here/.venv/bin/python" "$here/src/tools/python/reproduce_kim2016.py"
