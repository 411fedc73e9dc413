#!/usr/bin/env bash
# The Python package as a user gets it: `pip wheel` of the source tree (build isolation: the build
# environment fetches scikit-build-core, nanobind and the pinned mujoco from PyPI), installed with
# its Ray extra into a fresh virtual environment (which fetches mujoco, matplotlib and ray), then
# tests/python/wheel_check.py run there, given the build tree's command to compare with.
#   wheel_test.sh SOURCE_DIR PYTHON_WITH_PIP MJSTEPPER_CLI
set -euo pipefail
src=$1
python=$2
cli=$3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$python" -m pip wheel "$src" --no-deps -w "$work/dist" -q 2>&1 | grep -v "^WARNING: Location" || true
ls "$work"/dist/mjstepper-*.whl >/dev/null
python3 -m venv "$work/venv"
wheel=$(ls "$work"/dist/mjstepper-*.whl)
"$work/venv/bin/pip" install -q "$wheel[ray]" 2>&1 | grep -v "^WARNING: Location" || true
cd "$work"
"$work/venv/bin/python" "$src/tests/python/wheel_check.py" "$src" "$cli"
# Issue 33, item 7: the Python front-end's arguments fuzzed for 15 s (tests/fuzz/python_fuzz.py,
# atheris pinned in tests/fuzz/requirements-python.txt, installed into this venv).
MJSTEPPER_FUZZ_PYTHON="$work/venv/bin/python" bash "$src/tests/fuzz/run.sh" python 15
# Issue 19 item 8: python -m mjstepper.view on a virtual screen.
xvfb-run -a -s "-screen 0 1280x720x24" "$work/venv/bin/python" \
  "$src/tests/python/view_check.py" "$src"
