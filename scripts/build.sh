#!/usr/bin/env bash
# Configures and builds mjstepper in build/ (after installing what is missing). Extra arguments are
# build targets; none builds everything.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$here/scripts/bootstrap.sh"
generator=()
command -v ninja >/dev/null && [[ ! -f "$here/build/CMakeCache.txt" ]] && generator=(-G Ninja)
cmake -S "$here" -B "$here/build" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release >/dev/null
targets=()
for t in "$@"; do targets+=(--target "$t"); done
cmake --build "$here/build" --parallel 2 "${targets[@]}"
