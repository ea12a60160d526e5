#!/usr/bin/env bash
# Set-up on a fresh Debian 12 machine: install the Debian packages the project
# needs (only those missing), then configure and build in ./build.
# Sourced by scripts/main.sh and scripts/test.sh; safe to run again.
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(cmake g++ make pkg-config
  libeigen3-dev libhdf5-dev libtomlplusplus-dev libcli11-dev nlohmann-json3-dev libgtest-dev
  python3-numpy python3-scipy python3-statsmodels python3-h5py python3-matplotlib python3-pytest python3-pytest-timeout
  lammps python3-lammps liblammps-dev openmpi-bin
  yade chromium
  clang libclang-rt-14-dev libomp-dev  # scripts/sanitize.sh, scripts/fuzz.sh
  ccache)  # a compiler cache shared by every build and clone on the machine (CMakeLists.txt)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}" >/dev/null
fi

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DPython3_EXECUTABLE=/usr/bin/python3 >/dev/null
cmake --build build -j"$(nproc)"
