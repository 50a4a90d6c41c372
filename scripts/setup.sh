#!/bin/bash
# Installs the Debian 12 packages udvr needs (only those missing), then configures and builds
# udvr in Release under build/, and makes `import udvr` work in /usr/bin/python3 with no
# environment variable: a udvr.pth in the interpreter's site directory names build/python (as
# an editable install does; root: /usr/local/lib/python3.X/dist-packages, else the user's site
# directory). Idempotent: a second run only rebuilds what changed.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(build-essential cmake pkg-config libvtk9-dev libnetcdf-dev libtbb-dev nlohmann-json3-dev
          libcli11-dev libeigen3-dev libpng-dev zlib1g-dev libgtest-dev libbenchmark-dev
          pybind11-dev python3-dev python3-numpy python3-scipy python3-pytest clang-format
          libcairo2-dev
          # the notebook side of the Python package: xarray, plots, progress bars, tables, and
          # the notebook runner of the tests
          python3-xarray python3-matplotlib python3-tqdm python3-pandas python3-nbformat
          python3-nbclient python3-ipykernel
          # udvr serve: the HTTP server library, and the headless browser its page tests drive
          libcpp-httplib-dev chromium chromium-driver python3-selenium
          # the readers' fuzz targets (scripts/fuzz.sh): Clang with libFuzzer and the sanitizers
          clang libclang-rt-14-dev
          # `mpirun -np N udvr build -o m.pvti` (VTK's packages pull these in too)
          libopenmpi-dev openmpi-bin)
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

# `import udvr` from /usr/bin/python3: a .pth line naming this build's package folder.
python_dir="$(cd "$build_dir" && pwd)/python"
if [ -d "$python_dir/udvr" ]; then
    if [ "$(id -u)" -eq 0 ]; then
        site_dir=$(/usr/bin/python3 -c 'import site; print(site.getsitepackages()[0])')
    else
        site_dir=$(/usr/bin/python3 -m site --user-site)
    fi
    mkdir -p "$site_dir"
    if [ "$(cat "$site_dir/udvr.pth" 2>/dev/null)" != "$python_dir" ]; then
        echo "$python_dir" > "$site_dir/udvr.pth"
        echo "setup: $site_dir/udvr.pth -> $python_dir (import udvr in /usr/bin/python3)" >&2
    fi
fi
