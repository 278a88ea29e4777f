#!/usr/bin/env bash
# Installs the Debian 12 packages nucleon needs to build, test and render; skips the package
# manager entirely when everything is already there. Run as root (or with sudo available).
# `deps.sh bench` adds what the benchmark script uses: Bullet (the peer in the cloth comparison)
# and gnuplot (the plots).
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config
  libeigen3-dev libtbb-dev libembree-dev
  libgtest-dev libbenchmark-dev
  nlohmann-json3-dev libtinyobjloader-dev libstb-dev
  parallel
  pybind11-dev python3-dev python3-numpy python3-pytest
  libglfw3-dev libimgui-dev xvfb xauth libgl1-mesa-dri
)
if [[ "${1:-}" == "bench" ]]; then
  packages+=(libbullet-dev gnuplot-nox)
fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]} == 0)); then
  exit 0
fi

sudo=""
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "deps.sh: run as root to install: ${missing[*]}" >&2; exit 1; }
  sudo="sudo"
fi
echo "Installing: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
