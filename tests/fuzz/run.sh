#!/usr/bin/env bash
# Builds the fuzzers (tests/fuzz/config_fuzz.cc, drive_fuzz.cc, cli_fuzz.cc) with clang++-14,
# libFuzzer, ASan and UBSan, and runs one of them on its seed corpus.
#   bash tests/fuzz/run.sh                   config_fuzz, 45 s
#   bash tests/fuzz/run.sh 600               config_fuzz, 600 s
#   bash tests/fuzz/run.sh -runs=N           config_fuzz, N inputs
#   bash tests/fuzz/run.sh drive 20          drive_fuzz, 20 s (CI's short run, a ctest test)
#   bash tests/fuzz/run.sh drive -runs=N     drive_fuzz, N inputs
#   bash tests/fuzz/run.sh cli 15            cli_fuzz (the command line), 15 s
#   bash tests/fuzz/run.sh python -runs=N    python_fuzz.py (the Python front-end's arguments,
#                                            atheris) in MJSTEPPER_FUZZ_PYTHON, a Python with the
#                                            mjstepper wheel installed (wheel_test.sh makes one)
# The target, config (corpus tests/fuzz/corpus/), drive (tests/fuzz/corpus_drive/) or cli
# (tests/fuzz/corpus_cli/), comes first
# if given. Further arguments go to libFuzzer (e.g. -jobs=2). Inputs the run finds that add
# coverage are written to a scratch directory, never into the repository's corpus (see README for
# minimising it). A crash, a sanitizer report, a violated property or an input running over 1 s
# fails the run, leaving the input as crash-*/timeout-* in the build directory.
#   MJSTEPPER_FUZZ_BUILD  build directory (default: build/fuzz)
#   CXX_FUZZ              compiler (default: clang++-14)
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=${MJSTEPPER_FUZZ_BUILD:-$here/build/fuzz}
cxx=${CXX_FUZZ:-clang++-14}
target=config_fuzz
corpus=$here/tests/fuzz/corpus
if (($#)); then
  case $1 in
    config) shift ;;
    drive) target=drive_fuzz; corpus=$here/tests/fuzz/corpus_drive; shift ;;
    cli) target=cli_fuzz; corpus=$here/tests/fuzz/corpus_cli; shift ;;
    python) target=python; corpus=$here/tests/fuzz/corpus_python; shift ;;
  esac
fi
limit=(-max_total_time=45)
if (($#)); then
  case $1 in
    -runs=*) limit=("$1"); shift ;;
    [0-9]*) limit=(-max_total_time="$1"); shift ;;
  esac
fi
if [[ $target == python ]]; then
  # The installed package (no build here): atheris pinned in requirements-python.txt, the run in
  # an empty folder (the fuzzer checks that nothing is written there), artifacts kept beside the
  # other fuzzers'.
  py=${MJSTEPPER_FUZZ_PYTHON:?set MJSTEPPER_FUZZ_PYTHON to a Python with the mjstepper wheel installed}
  "$py" -m pip install -q -r "$here/tests/fuzz/requirements-python.txt" 2>&1 |
    grep -v "^WARNING: Location" || true
  mkdir -p "$build"
  scratch=$(mktemp -d)
  work=$(mktemp -d)
  trap 'rm -rf "$scratch" "$work"' EXIT
  cd "$work"
  start=$(date +%s)
  "$py" "$here/tests/fuzz/python_fuzz.py" -timeout=1 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$build/python-" "${limit[@]}" "$@" "$scratch" "$corpus"
  echo "run.sh: python_fuzz fuzzed $(( $(date +%s) - start )) s; corpus $(ls "$corpus" | wc -l)" \
    "seed files + $(ls "$scratch" | wc -l) new"
  exit 0
fi
command -v "$cxx" >/dev/null || { echo "run.sh: $cxx not found (scripts/bootstrap.sh installs clang-14)" >&2; exit 1; }

generator=()
command -v ninja >/dev/null && [[ ! -f "$build/CMakeCache.txt" ]] && generator=(-G Ninja)
cmake -S "$here/tests/fuzz" -B "$build" "${generator[@]}" -DCMAKE_CXX_COMPILER="$cxx" >/dev/null
cmake --build "$build" --parallel 2 --target "$target"

scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
# The sanitizers' options: a report ends the run (the runtimes are clang's, linked in the fuzzer).
export ASAN_OPTIONS="${ASAN_OPTIONS:-halt_on_error=1:detect_leaks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}"
cd "$build"
start=$(date +%s)
"./$target" -timeout=1 -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$build/" \
  "${limit[@]}" "$@" "$scratch" "$corpus"
echo "run.sh: $target fuzzed $(( $(date +%s) - start )) s; corpus $(ls "$corpus" | wc -l) seed" \
  "files + $(ls "$scratch" | wc -l) new"
