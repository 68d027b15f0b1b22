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
  libtbb-dev libfftw3-dev libfmt-dev
  # video frames decoded on one thread (io/video.cpp: FFmpeg's own libraries)
  libavformat-dev libavcodec-dev libswscale-dev libavutil-dev
  # header-only libraries
  catch2 libcli11-dev libtoml11-dev
  # fuzzing (scripts/fuzz.sh: libFuzzer targets built with clang, ASan + UBSan)
  clang-14 libfuzzer-14-dev
  # figure scripts (h5py: PIV fields in HDF5; opencv: video frames under the vectors)
  python3 python3-matplotlib python3-numpy python3-h5py python3-opencv
  # the Python module (python/: pybind11), its tests and its notebook (docs/notebooks)
  python3-dev pybind11-dev python3-pytest jupyter-nbconvert python3-nbclient python3-ipykernel
  # the report's checks in a real browser (tests/report: headless Chromium, HTML parser)
  chromium chromium-driver python3-selenium python3-html5lib
)
# studies (`shearzone study run`): Snakemake 7.21, and SLURM 22.05 with munge for --slurm and
# its test cluster. Installed with their recommended packages (the tested recipe: Snakemake
# imports some of them, e.g. its remote-storage modules).
WORKFLOW_PACKAGES=(snakemake slurm-wlm munge)

missing_of() {
  local p
  for p in "$@"; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
      echo "$p"
    fi
  done
}
mapfile -t missing < <(missing_of "${PACKAGES[@]}")
mapfile -t missing_wf < <(missing_of "${WORKFLOW_PACKAGES[@]}")
total=$(( ${#PACKAGES[@]} + ${#WORKFLOW_PACKAGES[@]} ))

if [ ${#missing[@]} -eq 0 ] && [ ${#missing_wf[@]} -eq 0 ]; then
  echo "setup: all ${total} system packages present"
  exit 0
fi

echo "setup: installing $(( ${#missing[@]} + ${#missing_wf[@]} )) missing package(s): ${missing[*]} ${missing_wf[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
# Another apt or dpkg (unattended upgrades on a fresh machine) may hold the locks:
# wait for it up to APT_LOCK_TIMEOUT seconds (default 600) instead of failing at once.
APT_LOCK_TIMEOUT="${APT_LOCK_TIMEOUT:-600}"
APT=($SUDO apt-get -o "DPkg::Lock::Timeout=$APT_LOCK_TIMEOUT")
if command -v fuser >/dev/null 2>&1 &&
   fuser /var/lib/dpkg/lock-frontend /var/lib/apt/lists/lock >/dev/null 2>&1; then
  echo "setup: another apt/dpkg process holds the lock; waiting up to ${APT_LOCK_TIMEOUT} s for it"
fi
# apt-get update takes the lists lock, which DPkg::Lock::Timeout does not cover: retry.
for attempt in $(seq 1 $(( APT_LOCK_TIMEOUT / 10 + 1 ))); do
  if "${APT[@]}" update -qq; then break; fi
  if [ "$attempt" -gt $(( APT_LOCK_TIMEOUT / 10 )) ]; then
    echo "setup: apt-get update failed (lock held for ${APT_LOCK_TIMEOUT} s, or no network)" >&2
    exit 1
  fi
  sleep 10
done
if [ ${#missing[@]} -gt 0 ]; then
  "${APT[@]}" install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
if [ ${#missing_wf[@]} -gt 0 ]; then
  "${APT[@]}" install -y -qq "${missing_wf[@]}" >/dev/null
fi
echo "setup: done"
