#!/bin/bash
# The main job: the paper's tangle experiment (Athawale et al. 2021, Fig. 4). Installs missing
# packages, builds, then writes figures and an error table to results/tangle (or $1).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
build_dir=${UDVR_BUILD_DIR:-build}
out=${1:-results/tangle}
mkdir -p "$out"
udvr="$build_dir/udvr"
"$udvr" generate tangle --dims 64 -o "$out/tangle.vti"
"$udvr" perturb "$out/tangle.vti" --members 50 --noise bimodal --seed 1 -o "$out/tangle_ensemble.nc"
"$udvr" build "$out/tangle_ensemble.nc" --quantiles 8 --gmm 4 -o "$out/tangle_model.vti"
