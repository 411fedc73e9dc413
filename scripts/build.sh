#!/usr/bin/env bash
# Configures and builds mjstepper in build/ (after installing what is missing). Extra arguments are
# build targets; none builds everything.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$here/scripts/bootstrap.sh"
generator=()
command -v ninja >/dev/null && [[ ! -f "$here/build/CMakeCache.txt" ]] && generator=(-G Ninja)
# A first configure picks the compiler that `pip install .` picks for the package ($CXX, else the
# Python's sysconfig CXX, as scikit-build-core does): the two builds then compile the same commands
# and ccache hands the package the tree's objects (CMakeLists.txt).
if [[ -z ${CXX:-} && ! -f "$here/build/CMakeCache.txt" ]]; then
  cxx=$("$here/.venv/bin/python" -c \
    'import sysconfig; print((sysconfig.get_config_var("CXX") or "").split(" ")[0])')
  if [[ -n $cxx ]] && command -v "$cxx" >/dev/null; then export CXX=$cxx; fi
fi
cmake -S "$here" -B "$here/build" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release >/dev/null
targets=()
for t in "$@"; do targets+=(--target "$t"); done
cmake --build "$here/build" --parallel 2 "${targets[@]}"
