#!/bin/bash
# The main job: the paper's tangle experiment (Athawale et al. 2021, Fig. 4). Installs missing
# packages, builds, then writes the figure panel, difference images, report.md and the error
# table (results.csv / results.json) to results/tangle (or the folder given as $1).
# Extra arguments go to `udvr experiment` (e.g. --quick).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
build_dir=${UDVR_BUILD_DIR:-build}
out=${1:-results/tangle}
shift || true
"$build_dir/udvr" experiment tangle -o "$out" "$@"
echo "run_tangle: figure $out/figure.png, table $out/results.csv, report $out/report.md" >&2
