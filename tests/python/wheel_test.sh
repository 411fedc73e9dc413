#!/usr/bin/env bash
# The Python package as a user gets it: `pip wheel` of the source tree (build isolation: the build
# environment fetches scikit-build-core and the pinned mujoco from PyPI), installed with its Ray
# extra into a fresh virtual environment (which fetches mujoco and ray), then
# tests/python/wheel_check.py run there, given a C++ sweep to compare the Ray sweep with.
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
"$cli" sweep "$src/models/tsui_rigid.xml" --speeds 40,45,85,170rpm --settle 0.2 --measure 0.2 \
  --quiet --out "$work/cpp_sweep" >/dev/null
"$cli" map "$src/models/tsui_coupling.xml" --speeds 40,85rpm --vary stiffness:coupling=20,50 \
  --settle 0.2 --measure 0.2 --quiet --out "$work/cpp_map" >/dev/null
cd "$work"
"$work/venv/bin/python" "$src/tests/python/wheel_check.py" "$src" "$work/cpp_sweep.csv" \
  "$work/cpp_map.csv"
