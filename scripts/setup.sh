#!/bin/bash
# Installs the Debian 12 packages udvr needs (only those missing), then configures and builds
# udvr in Release under build/. Idempotent: a second run only rebuilds what changed.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(build-essential cmake pkg-config libvtk9-dev libnetcdf-dev libtbb-dev nlohmann-json3-dev
          libcli11-dev libeigen3-dev libpng-dev zlib1g-dev libgtest-dev libbenchmark-dev
          pybind11-dev python3-dev python3-numpy python3-scipy python3-pytest clang-format
          libcairo2-dev)
missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
    echo "setup: installing ${missing[*]}" >&2
    if [ "$(id -u)" -eq 0 ]; then SUDO=; else SUDO=sudo; fi
    $SUDO apt-get update -qq >&2
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends \
        "${missing[@]}" >&2
fi

build_dir=${UDVR_BUILD_DIR:-build}
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release -DUDVR_WERROR="${UDVR_WERROR:-OFF}" >&2
cmake --build "$build_dir" -j "$(nproc)" >&2
