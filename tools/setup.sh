#!/usr/bin/env bash
# Installs the Debian packages nonholo needs (only those missing) and configures and builds
# the project in ./build. Sourced by tools/main.sh and tools/test.sh.
set -euo pipefail

NONHOLO_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
NONHOLO_BUILD="${NONHOLO_BUILD:-$NONHOLO_ROOT/build}"

packages=(g++ make cmake libeigen3-dev libsuitesparse-dev libgtest-dev libgmock-dev
          libbenchmark-dev libcli11-dev liblapack-dev libsundials-dev nlohmann-json3-dev
          python3-dev python3-numpy pybind11-dev python3-pytest python3-jsonschema
          python3-venv python3-pip python3-setuptools python3-wheel python3-build mypy
          libhdf5-dev python3-h5py python3-matplotlib python3-pil ffmpeg chromium
          libopenmpi-dev openmpi-bin)

# Installs the given Debian packages that are missing (apt-get update once per shell).
nonholo_require() {
  local missing=() p
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  ((${#missing[@]})) || return 0
  echo "nonholo: installing ${missing[*]}" >&2
  local sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  if [ -z "${NONHOLO_APT_UPDATED:-}" ]; then
    $sudo apt-get update
    NONHOLO_APT_UPDATED=1
  fi
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y --no-install-recommends "${missing[@]}"
}
nonholo_require "${packages[@]}"

# Builds the given targets (all when none).
nonholo_build() {
  cmake -S "$NONHOLO_ROOT" -B "$NONHOLO_BUILD" -DCMAKE_BUILD_TYPE=Release >/dev/null
  if (($#)); then
    for target in "$@"; do cmake --build "$NONHOLO_BUILD" --target "$target" -j "$(nproc)"; done
  else
    cmake --build "$NONHOLO_BUILD" -j "$(nproc)"
  fi
}
