#!/usr/bin/env bash
# Installs what is missing, builds everything and runs every test (GoogleTest and Python under ctest).
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$here/scripts/build.sh"
cd "$here/build"
ctest --output-on-failure --parallel 2
