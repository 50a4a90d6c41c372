#!/bin/bash
# Issue 10's frame-time ratios: each model rendered with the 1D TF (data/tf/tangle.json) and with
# a 2D TF, alternating in one run, three rounds, the load average printed (docs/models.md,
# "Stop 29" and "Stop 30"). The 2D TF is the same 1D TF sampled on 1024 × 2 raster points
# (x over [−7, 35.3], y over [0, 200]: every row alike, so the two frames classify with the same
# TF content) or, with TF2=widget, data/tf2/tangle.json (varying in y).
# Model: the 64³ tangle, 20 members of the default bimodal noise, q = 8, GMM K = 4.
#   bash bench/tf2_ratio.sh                      # one thread, 512², all quantile models + mean
#   THREADS=2 TF2=widget MODELS="quantile-range iqr" bash bench/tf2_ratio.sh
set -euo pipefail
cd "$(dirname "$0")/.."
U=${UDVR:-build/udvr}
W=${WORK:-/tmp/udvr-tf2-ratio}
THREADS=${THREADS:-1}
ROUNDS=${ROUNDS:-3}
FRAMES=${FRAMES:-5}
SIZE=${SIZE:-512}
MODELS=${MODELS:-mean quantile-range quantile-mean quantile-mean-mass iqr quartile-middle}
PY=${PYTHON:-python3}
"$PY" -c "import numpy" 2>/dev/null || PY=/usr/bin/python3  # Debian's, with python3-numpy
[ -x "$U" ] || { echo "tf2_ratio.sh: no udvr binary at $U (build first, or set UDVR)" >&2; exit 1; }
mkdir -p "$W"
if [ ! -f "$W/model.vti" ]; then
    "$U" generate tangle --dims 64 -o "$W/tangle.vti"
    "$U" perturb "$W/tangle.vti" --members 20 --seed 1 -o "$W/ens.nc"
    "$U" build "$W/ens.nc" -o "$W/model.vti"
fi
if [ "${TF2:-1d}" = widget ]; then
    tf2=(--tf2 data/tf2/tangle.json)
else
    "$PY" - "$W/tf2_1d.npy" <<'EOF'
import json, sys
import numpy as np
tf = json.load(open("data/tf/tangle.json"))[0]
rgb = np.array(tf["RGBPoints"]).reshape(-1, 4)
alpha = np.array(tf["Points"]).reshape(-1, 4)  # midpoint 0.5, sharpness 0: linear
x = np.linspace(-7.0, 35.3, 1024)
row = np.stack([np.interp(x, rgb[:, 0], rgb[:, c]) for c in (1, 2, 3)]
               + [np.interp(x, alpha[:, 0], alpha[:, 1])], axis=-1)
np.save(sys.argv[1], np.stack([row, row]).astype(np.float32))  # (H = 2, W = 1024, 4)
EOF
    # shellcheck disable=SC2054  # the commas are the domain's, in one argument
    tf2=(--tf2 "$W/tf2_1d.npy" --tf2-domain=-7,35.3,0,200)
fi
frameMs() {  # the median frame time of one render, ms
    "$U" render "$W/model.vti" "$@" --size "$SIZE" --frames "$FRAMES" --threads "$THREADS" \
        -o "$W/frame.png" 2>&1 | grep -o "in [0-9.]* ms" | head -1 | grep -o "[0-9.]*"
}
for r in $(seq "$ROUNDS"); do
    for m in $MODELS; do
        a=$(frameMs --model "$m" --tf data/tf/tangle.json)
        b=$(frameMs --model "$m" "${tf2[@]}")
        echo "round $r $m: 1D $a ms, 2D $b ms, ratio $("$PY" -c "print(f'{$b / $a:.2f}')")," \
             "load $(cut -d' ' -f1 /proc/loadavg)"
    done
done
