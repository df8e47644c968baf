#!/usr/bin/env bash
# Installs everything pcl_mi needs to build, test and run on Debian 12, from Debian's
# archive. Idempotent: packages already present are not fetched again.
set -euo pipefail
packages=(
  build-essential cmake pkg-config
  libpcl-dev libeigen3-dev libflann-dev libboost-all-dev libvtk9-dev libopenmpi-dev
  libgtest-dev libbenchmark-dev
  ocl-icd-opencl-dev opencl-headers pocl-opencl-icd clinfo
  clang libclang-rt-14-dev
  python3-matplotlib python3-numpy xvfb xauth
  pybind11-dev python3-dev python3-pytest
  pcl-tools
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages present"
  exit 0
fi
sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
echo "setup: installing ${missing[*]}"
$sudo apt-get update -q
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q --no-install-recommends "${missing[@]}"
