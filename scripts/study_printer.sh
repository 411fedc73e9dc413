#!/usr/bin/env bash
# The printer study (issue 18): models/corexy.xml's resonance tests, input shapers, ringing with
# and without them, and the drives; writes docs/studies/printer.md, renders/printer/ and
# logs/printer/. About 2-3 minutes after the build on the 2-core machine of BENCHMARKS.md.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$here/scripts/build.sh" mjstepper_cli mjstepper
cd "$here"
.venv/bin/python src/tools/python/study_printer.py
