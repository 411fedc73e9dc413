#!/usr/bin/env bash
# Installs what mjstepper needs and is missing; does nothing when everything is there.
#   Debian packages (only when root): compiler, CMake, Ninja, ccache, Eigen, GoogleTest, Google Benchmark,
#   CLI11, fmt, OSMesa, ffmpeg; Xvfb, xwd and Mesa's GL for the test of MuJoCo's viewer.
#   A project-local virtual environment .venv with requirements.txt (the pinned mujoco wheel).
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

# Why each package is here: see README.md, "Dependencies".
packages=(g++ cmake ninja-build ccache pkg-config python3-venv libeigen3-dev libgtest-dev libgmock-dev
          libbenchmark-dev libcli11-dev libfmt-dev libtinyxml2-dev libosmesa6-dev libpng-dev
          ffmpeg xvfb xauth x11-apps libgl1 libglx-mesa0 libgl1-mesa-dri
          # clang and its runtimes (libFuzzer, ASan, UBSan): the config fuzzer, tests/fuzz/run.sh
          clang-14 libclang-rt-14-dev)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  if [[ $(id -u) -eq 0 ]]; then
    echo "bootstrap: installing Debian packages: ${missing[*]}"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  else
    echo "bootstrap: missing Debian packages (run as root to install): ${missing[*]}" >&2
    exit 1
  fi
fi

venv="$here/.venv"
# The venv is up to date when it was made from this very requirements.txt.
stamp="$venv/.requirements.sha256"
want=$(sha256sum "$here/requirements.txt" | cut -d' ' -f1)
if [[ ! -x "$venv/bin/python" || ! -f "$stamp" || "$(cat "$stamp")" != "$want" ]]; then
  echo "bootstrap: installing requirements.txt into a new $venv"
  # Made afresh: upgrading in place can break a package that changed shape (mujoco 3.x was one
  # wheel; 4.0 is mujoco + mujoco-core, and pip over 3.x leaves the bindings half removed).
  rm -rf "$venv"
  python3 -m venv "$venv"
  "$venv/bin/python" -m pip install -q -r "$here/requirements.txt" 2>&1 | grep -v "^WARNING: Location" || true
  "$venv/bin/python" -c 'import mujoco, matplotlib' && echo "$want" > "$stamp"
fi
