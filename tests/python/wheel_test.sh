#!/usr/bin/env bash
# The Python package as a user gets it: `pip wheel` of the source tree (build isolation: the build
# environment fetches scikit-build-core and the pinned mujoco from PyPI), installed into a fresh
# virtual environment (which fetches mujoco), then tests/python/wheel_check.py run there.
#   wheel_test.sh SOURCE_DIR PYTHON_WITH_PIP
set -euo pipefail
src=$1
python=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$python" -m pip wheel "$src" --no-deps -w "$work/dist" -q 2>&1 | grep -v "^WARNING: Location" || true
ls "$work"/dist/mjstepper-*.whl >/dev/null
python3 -m venv "$work/venv"
"$work/venv/bin/pip" install -q "$work"/dist/mjstepper-*.whl 2>&1 | grep -v "^WARNING: Location" || true
cd "$work"
"$work/venv/bin/python" "$src/tests/python/wheel_check.py" "$src"
