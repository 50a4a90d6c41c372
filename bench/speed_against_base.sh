#!/bin/bash
# Frame times of two builds side by side, alternated in one run (issue 31's "no model slower by
# more than 5 %"): render_bench's 1D models (64³, 1 thread) and the CLI's --frames median for 2D
# and bivariate TFs (data/tf2/tangle.json on the 64³ tangle, 20 members, q = 8). Prints one CSV
# line per frame: side, what, load average, time.
#   BASE=/work/base/build MAIN=build bash bench/speed_against_base.sh
set -euo pipefail
cd "$(dirname "$0")/.."
BASE=${BASE:?set BASE to the other build folder}
MAIN=${MAIN:-build}
W=${WORK:-/tmp/udvr-speed-base}
ROUNDS=${ROUNDS:-3}
TF2=$PWD/data/tf2/tangle.json
mkdir -p "$W"
if [ ! -f "$W/model.vti" ]; then
    "$MAIN/udvr" generate tangle --dims 64 -o "$W/tangle.vti"
    "$MAIN/udvr" perturb "$W/tangle.vti" --members 20 --seed 1 -o "$W/ens.nc"
    "$MAIN/udvr" build "$W/ens.nc" -o "$W/model.vti"
    "$MAIN/udvr" perturb "$W/tangle.vti" --members 20 --seed 3 --noise gaussian -o "$W/ens3.nc"
    "$MAIN/udvr" build "$W/ens3.nc" -o "$W/model3.vti"
fi
load() { cut -d' ' -f1 /proc/loadavg; }
frameOf() {  # side build label input args...
    local side=$1 dir=$2 label=$3 input=$4
    shift 4
    local ms
    ms=$(UDVR_NO_PROGRESS=1 "$dir/udvr" render "$input" "$@" --threads 1 -o "$W/o.png" 2>&1 |
         grep -oE "median_ms=[0-9.]+" | head -1) || true  # a build that refuses the frame: "-"
    ms=${ms#median_ms=}
    echo "$side,$label,$(load),${ms:--}"
}
frame() {  # side build label args...  (the model built from the 64³ tangle's ensemble)
    local side=$1 dir=$2 label=$3
    shift 3
    frameOf "$side" "$dir" "$label" "$W/model.vti" "$@"
}
for r in $(seq "$ROUNDS"); do
    for side in base main; do
        dir=$BASE
        [ "$side" = main ] && dir=$MAIN
        "$dir/render_bench" --benchmark_filter='BM_Render/model:(0|1|3|4|5|6|7|8|9|10)/n:64/threads:1' \
            --benchmark_format=csv 2>/dev/null | grep BM_ | cut -d, -f1,3 | sed "s/^/$side,/;s/,/,1d:/1;s/\$/,$(load)/"
        for m in mean quantile-range quantile-mean iqr quartile-middle; do
            frame "$side" "$dir" "2d-$m-128" --model "$m" --tf2 "$TF2" --size 128 --frames 3
        done
        # The models render_bench's list leaves out, by the CLI (1D: the default TF, 128²):
        # the quartile views, members (of the ensemble the model was built from) and the exact
        # uniform kernel (`uniform` itself before issue 33 made it the fast form).
        for m in quartile-lower quartile-middle quartile-upper; do
            frame "$side" "$dir" "1d-$m-128" --model "$m" --size 128 --frames 3
        done
        frameOf "$side" "$dir" 1d-members-128 "$W/ens.nc" --model members --size 128 --frames 3
        exact=uniform-exact
        [ "$side" = base ] && exact=uniform
        frame "$side" "$dir" 1d-uniform-exact-64 --model "$exact" --size 64 --frames 1
        for m in quartile-lower quartile-upper; do
            frame "$side" "$dir" "2d-$m-128" --model "$m" --tf2 "$TF2" --size 128 --frames 3
        done
        frameOf "$side" "$dir" 2d-members-64 "$W/ens.nc" --model members --tf2 "$TF2" --size 64 \
            --frames 1
        frame "$side" "$dir" 2d-gaussian-16 --model gaussian --tf2 "$TF2" --size 16 --frames 1
        # uniform-fast with a TF2: the lattice rule before issue 33, since then an alias of
        # `uniform` (within 1e-3 of uniform-exact, ~20 ms a sample): 8², one frame.
        frame "$side" "$dir" 2d-uniform-fast-8 --model uniform-fast --tf2 "$TF2" --size 8 --frames 1
        for m in mean quantile-range; do
            frame "$side" "$dir" "biv-$m-128" --model "$m" --tf2 "$TF2" --second "$W/model3.vti" \
                --size 128 --frames 3
        done
        frame "$side" "$dir" biv-gaussian-48 --model gaussian --tf2 "$TF2" --second "$W/model3.vti" \
            --size 48 --frames 1
    done
done
