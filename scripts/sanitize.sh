#!/usr/bin/env bash
# Builds everything (core, plugin, tools, tests, benchmarks) with AddressSanitizer, LeakSanitizer
# and UndefinedBehaviorSanitizer (g++, -fno-sanitize-recover=all) in build-asan/, and runs the whole
# ctest suite there. Not part of CI (it takes several times the normal suite's time); see README,
# "Sanitizers and fuzzing". Extra arguments go to ctest (e.g. -R Config).
#   MJSTEPPER_ASAN_BUILD  build directory (default: build-asan/ beside build/)
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$here/scripts/bootstrap.sh"
dir=${MJSTEPPER_ASAN_BUILD:-$here/build-asan}
mkdir -p "$dir"
[[ -f "$dir/.gitignore" ]] || echo '*' > "$dir/.gitignore"  # git ignores the whole tree
generator=()
command -v ninja >/dev/null && [[ ! -f "$dir/CMakeCache.txt" ]] && generator=(-G Ninja)
cmake -S "$here" -B "$dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
      -DMJSTEPPER_SANITIZE=ON >/dev/null
cmake --build "$dir" --parallel 2

# Every process of the suite inherits these: the tests, the mjstepper CLI they spawn, the fuzzer's
# run (clang's runtime reads the same variables). A report stops the process with a stack; leaks
# are checked at exit, less the suppressions file's entries (Mesa's, MuJoCo's, Python's: none ours).
# The Python tests get the ASan runtime preloaded through ctest (tests/CMakeLists.txt, at the end).
export ASAN_OPTIONS="halt_on_error=1:abort_on_error=0:detect_leaks=1:print_stacktrace=1:strict_string_checks=1:check_initialization_order=1:detect_odr_violation=2"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
# use_tls=0: LeakSanitizer's tracer (gcc 12's libsanitizer) crashes with SIGSEGV reading the
# dynamic TLS of dlopen'ed libraries on this glibc ("DTLS 6 at 0x351-0x100001453", then "Tracer
# caught signal 11"), which failed Attach.PackageMeshesNeedTheirFolder and the renderer's tests at
# exit after they passed; thread-local storage is then not a root of the leak search.
export LSAN_OPTIONS="suppressions=$here/tests/sanitizers/lsan.supp:print_suppressions=1:use_tls=0"
cd "$dir"
start=$(date +%s)
status=0
ctest --output-on-failure --parallel 2 "$@" || status=$?
echo "sanitize: ctest took $(( $(date +%s) - start )) s (exit $status)"
exit "$status"
