#!/usr/bin/env bash
# Builds the config/profile fuzzer (tests/fuzz/config_fuzz.cc) with clang++-14, libFuzzer, ASan and
# UBSan, and runs it on the seed corpus tests/fuzz/corpus/.
#   bash tests/fuzz/run.sh             45 s (CI's short run, a ctest test)
#   bash tests/fuzz/run.sh 600         600 s
#   bash tests/fuzz/run.sh -runs=N     N inputs
# Further arguments go to libFuzzer (e.g. -jobs=2). Inputs the run finds that add coverage are
# written to a scratch directory, never into the repository's corpus (see README for minimising it
# into tests/fuzz/corpus/). A crash, a sanitizer report, a violated property or an input running
# over 1 s fails the run, leaving the input as crash-*/timeout-* in the build directory.
#   MJSTEPPER_FUZZ_BUILD  build directory (default: build/fuzz)
#   CXX_FUZZ              compiler (default: clang++-14)
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=${MJSTEPPER_FUZZ_BUILD:-$here/build/fuzz}
cxx=${CXX_FUZZ:-clang++-14}
limit=(-max_total_time=45)
if (($#)); then
  case $1 in
    -runs=*) limit=("$1"); shift ;;
    [0-9]*) limit=(-max_total_time="$1"); shift ;;
  esac
fi
command -v "$cxx" >/dev/null || { echo "run.sh: $cxx not found (scripts/bootstrap.sh installs clang-14)" >&2; exit 1; }

generator=()
command -v ninja >/dev/null && [[ ! -f "$build/CMakeCache.txt" ]] && generator=(-G Ninja)
cmake -S "$here/tests/fuzz" -B "$build" "${generator[@]}" -DCMAKE_CXX_COMPILER="$cxx" >/dev/null
cmake --build "$build" --parallel 2

scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
# The sanitizers' options: a report ends the run (the runtimes are clang's, linked in the fuzzer).
export ASAN_OPTIONS="${ASAN_OPTIONS:-halt_on_error=1:detect_leaks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}"
cd "$build"
start=$(date +%s)
./config_fuzz -timeout=1 -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$build/" \
  "${limit[@]}" "$@" "$scratch" "$here/tests/fuzz/corpus"
echo "run.sh: fuzzed $(( $(date +%s) - start )) s; corpus $(ls "$here/tests/fuzz/corpus" | wc -l) seed files + $(ls "$scratch" | wc -l) new"
