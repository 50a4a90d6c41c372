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
installed() { dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q "install ok installed"; }
if [ "$(id -u)" -eq 0 ]; then SUDO=; else SUDO=sudo; fi
missing=()
for p in "${packages[@]}"; do
    installed "$p" || missing+=("$p")
done
apt_updated=no
if [ ${#missing[@]} -gt 0 ]; then
    echo "setup: installing ${missing[*]}" >&2
    $SUDO apt-get update -qq >&2
    apt_updated=yes
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends \
        "${missing[@]}" >&2
fi

build_dir=${UDVR_BUILD_DIR:-build}

# The ParaView plugin (docs/paraview.md; UDVR_PARAVIEW=ON|OFF|AUTO, default AUTO): ParaView, its
# headers and Xvfb (Debian's ParaView draws with GLX only; the tests run pvbatch under
# xvfb-run), where apt installs them without removing any package (--no-remove). ParaView's
# Python (python3-paraview, for pvbatch's paraview.simple and the plugin's wrapping) Conflicts
# with python3-vtk9, which udvr needs: it is unpacked from apt's archive into the build tree
# (scripts/paraview_python.sh), never installed over it. Where any of that fails the plugin is
# skipped, said in one line (CMake says why too).
paraview=${UDVR_PARAVIEW:-AUTO}
if [ "$paraview" != OFF ]; then
    pv_missing=()
    for p in paraview paraview-dev xvfb xauth; do
        installed "$p" || pv_missing+=("$p")
    done
    if [ ${#pv_missing[@]} -gt 0 ]; then
        echo "setup: installing ${pv_missing[*]} (the ParaView plugin)" >&2
        [ $apt_updated = yes ] || $SUDO apt-get update -qq >&2
        if ! DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends \
            --no-remove "${pv_missing[@]}" >&2; then
            echo "setup: the ParaView plugin is skipped: apt cannot install ${pv_missing[*]} without removing packages" >&2
        fi
    fi
    if installed paraview && ! installed python3-paraview; then
        bash scripts/paraview_python.sh "$build_dir/paraview-python" ||
            echo "setup: the ParaView plugin is skipped: python3-paraview could not be unpacked from apt's archive" >&2
    fi
fi

cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release -DUDVR_WERROR="${UDVR_WERROR:-OFF}" \
    -DUDVR_PARAVIEW="$paraview" >&2
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
