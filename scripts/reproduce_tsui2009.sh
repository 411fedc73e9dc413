#!/usr/bin/env bash
# Regenerates docs/reproduction/tsui2009.md and renders/tsui2009/*.png from a clean build.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$here/scripts/build.sh" mjstepper_cli mjstepper
"$here/.venv/bin/python" "$here/src/tools/python/reproduce_tsui2009.py"
