#!/usr/bin/env bash
# The Python package as a user gets it, in stages that ctest runs as separate tests (so that the
# checks run beside the other tests instead of one after another):
#   wheel_test.sh install SOURCE_DIR PYTHON_WITH_PIP VENV
#       `pip wheel` of the source tree (build isolation: the build environment fetches
#       scikit-build-core, nanobind and the pinned mujoco from PyPI), as a user at a terminal
#       builds it, then installed with its Ray extra into VENV, made afresh (which fetches mujoco,
#       matplotlib and ray). The ctest fixture the other stages need.
#   wheel_test.sh check SOURCE_DIR VENV MJSTEPPER_CLI [CLASS]
#       tests/python/wheel_check.py (one of its test classes, or all) in VENV, in an empty folder,
#       given the build tree's command to compare with.
#   wheel_test.sh fuzz SOURCE_DIR VENV SECONDS
#       issue 33, item 7: the Python front-end's arguments fuzzed (tests/fuzz/python_fuzz.py).
#   wheel_test.sh view SOURCE_DIR VENV
#       issue 19, item 8: python -m mjstepper.view on a virtual screen.
set -euo pipefail
stage=$1
src=$2
case $stage in
  install)
    python=$3
    venv=$4
    work=$(mktemp -d)
    trap 'rm -rf "$work"' EXIT
    # Built in a build folder of its own so that every file is compiled, through ccache, which
    # hands it the objects the tree compiled with the same commands (CXX is the tree's compiler):
    # it compiles only the bindings. Issue 32, item 6: pip hides the build's output, so the build
    # numbers each compile on the terminal (tests/python/pty_run.py gives pip one); the terminal
    # must show every one, 1 to N.
    python3 "$src/tests/python/pty_run.py" "$work/terminal.txt" \
      "$python" -m pip wheel "$src" --no-deps -w "$work/dist" -q -C build-dir="$work/build" |
      grep -v "^WARNING: Location" || true
    ls "$work"/dist/mjstepper-*.whl >/dev/null
    echo "wheel_test: built the wheel in $SECONDS s"
    tr -d '\r' < "$work/terminal.txt" | grep -o "^mjstepper: compiling [0-9]* of [0-9]*:" |
      awk '{if (!($3 in seen)) distinct++; seen[$3] = 1; total = $5 + 0; lines++}
           END {if (lines == 0 || total < 10 || lines != total || distinct != total) {
                  printf "the build showed %d compile lines of %d on the terminal\n", lines, total
                  exit 1}
                printf "the build numbered its %d compiles on the terminal\n", total}'
    rm -rf "$venv"
    python3 -m venv "$venv"
    wheel=$(ls "$work"/dist/mjstepper-*.whl)
    "$venv/bin/pip" install -q "$wheel[ray]" -r "$src/tests/fuzz/requirements-python.txt" 2>&1 |
      grep -v "^WARNING: Location" || true
    "$venv/bin/python" -c "import mjstepper, ray, atheris"
    echo "wheel_test: built and installed it into a fresh venv in $SECONDS s"
    ;;
  check)
    venv=$3
    cli=$4
    work=$(mktemp -d)
    trap 'rm -rf "$work"' EXIT
    cd "$work"
    "$venv/bin/python" "$src/tests/python/wheel_check.py" "$src" "$cli" "${@:5}"
    ;;
  fuzz)
    venv=$3
    MJSTEPPER_FUZZ_PYTHON="$venv/bin/python" bash "$src/tests/fuzz/run.sh" python "$4"
    ;;
  view)
    venv=$3
    xvfb-run -a -s "-screen 0 1280x720x24" "$venv/bin/python" \
      "$src/tests/python/view_check.py" "$src"
    ;;
  *)
    echo "wheel_test.sh: unknown stage $stage (install, check, fuzz or view)" >&2
    exit 2
    ;;
esac
