#!/usr/bin/env bash
# scripts/setup.sh: install the system packages shearzone needs (Debian 12).
#
# This file is the single list of system packages for building, testing, running
# the demo and drawing figures. It is idempotent: packages already installed are
# left alone, and apt is only called for the missing ones.
set -euo pipefail

PACKAGES=(
  # toolchain
  g++ cmake ninja-build ccache pkg-config git
  # libraries (Debian 12: OpenCV 4.6, Eigen 3.4, Ceres 2.1, GSL 2.7, HDF5 1.10)
  libopencv-dev libeigen3-dev libceres-dev libgsl-dev libhdf5-dev
  libtbb-dev libfftw3-dev libfmt-dev libavutil-dev
  # header-only libraries
  catch2 libcli11-dev libtoml11-dev
  # fuzzing (scripts/fuzz.sh: libFuzzer targets built with clang, ASan + UBSan)
  clang-14 libfuzzer-14-dev
  # figure scripts (h5py: PIV fields in HDF5; opencv: video frames under the vectors)
  python3 python3-matplotlib python3-numpy python3-h5py python3-opencv
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} system packages present"
  exit 0
fi

echo "setup: installing ${#missing[@]} missing package(s): ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "setup: done"
