#!/usr/bin/env bash
# Installs the Debian 12 packages posekit needs, only those missing. Needs root (or sudo).
set -euo pipefail
packages=(build-essential cmake ninja-build ccache git pkg-config
          libeigen3-dev libpcl-dev libflann-dev libvtk9-dev libopencv-dev libpng-dev libjpeg-dev zlib1g-dev libgtest-dev
          nlohmann-json3-dev libsuitesparse-dev xvfb xauth clang clang-format libclang-rt-14-dev
          pybind11-dev python3-dev python3-numpy python3-pytest python3-venv python3-pip python3-build python3-wheel chromium
          python3-distributed python3-pandas)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi
echo "install-deps: installing ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "install-deps: need root or sudo to apt-get install ${missing[*]}" >&2; exit 1; }
  SUDO=sudo
fi
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
