#!/bin/bash
# udvr's CPU ray caster against VTK's (bench/peer/vtk_render.py, vtkFixedPointVolumeRayCastMapper)
# on the same tangle volume, TF, camera (azimuth 30, elevation 20, view angle 30), step (half the
# spacing), opacity unit distance and image size. The two renderers run alternately, ROUNDS
# times each, in one session (the host is noisy: compare medians and minima of the same run).
# Each run renders one warm-up frame and then FRAMES timed frames in one process, so loading and
# VTK's table/min-max-volume building are not counted. Prints a Markdown table and the RMSE
# (SPEC §6) between the two images.
#
# Knobs (environment): NS="64 256" SIZE=512 THREADS=2 FRAMES=10 ROUNDS=3 UNIT=0.0793650794
#   MAPPER=fixed MODEL=mean UDVR=build/udvr PEER=<…>/shared/bench/peer OUT=/tmp/udvr_compare_vtk
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
PY=/usr/bin/python3
NS=${NS:-"64 256"}
SIZE=${SIZE:-512}
THREADS=${THREADS:-2}
FRAMES=${FRAMES:-10}
ROUNDS=${ROUNDS:-3}
UNIT=${UNIT:-0.0793650794}
MAPPER=${MAPPER:-fixed}
MODEL=${MODEL:-mean}
UDVR=${UDVR:-$repo/build/udvr}
PEER=${PEER:-$repo/../shared/bench/peer}
OUT=${OUT:-/tmp/udvr_compare_vtk}

[ -x "$UDVR" ] || { echo "compare_vtk: no udvr binary at $UDVR (build it, or set UDVR)" >&2; exit 2; }
[ -f "$PEER/vtk_render.py" ] || { echo "compare_vtk: no vtk_render.py in $PEER (set PEER)" >&2; exit 2; }

missing=()
"$PY" -c 'import vtk' 2>/dev/null || missing+=(python3-vtk9)
"$PY" -c 'import numpy' 2>/dev/null || missing+=(python3-numpy)
command -v xvfb-run >/dev/null || missing+=(xvfb)
if [ ${#missing[@]} -gt 0 ]; then
    echo "compare_vtk: installing ${missing[*]}" >&2
    if [ "$(id -u)" -eq 0 ]; then SUDO=; else SUDO=sudo; fi
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}" >&2
fi
# One X server for the whole comparison (Debian's VTK needs GLX even offscreen).
if [ -z "${DISPLAY:-}" ]; then
    exec xvfb-run -a -s "-screen 0 1280x1024x24" "$0" "$@"
fi

mkdir -p "$OUT/data"
for n in $NS; do
    [ -f "$OUT/data/tangle_$n.raw" ] || "$PY" "$PEER/make_tangle.py" -n "$n" -o "$OUT/data" >&2
done
[ -f "$OUT/data/tangle_tf.json" ] || "$PY" "$PEER/make_tangle.py" -n 2 -o "$OUT/data" >&2

results="$OUT/results.tsv"
: > "$results"
for n in $NS; do
    sp=$(awk "BEGIN{printf \"%.10g\", 5/($n-1)}")
    sd=$(awk "BEGIN{printf \"%.10g\", 2.5/($n-1)}")
    raw="$OUT/data/tangle_$n.raw"
    for r in $(seq "$ROUNDS"); do
        echo "== tangle $n^3, round $r" >&2
        "$PY" "$PEER/vtk_render.py" "$raw" --dims "$n" "$n" "$n" --spacing "$sp" \
            --origin -2.5 -2.5 -2.5 --tf "$OUT/data/tangle_tf.json" --size "$SIZE" "$SIZE" \
            --azimuth 30 --elevation 20 --view-angle 30 --sample-distance "$sd" \
            --unit-distance "$UNIT" --threads "$THREADS" --frames "$FRAMES" --warmup 1 \
            --mapper "$MAPPER" --out "$OUT/vtk_$n.png" > "$OUT/vtk_$n.log" 2>&1 ||
            { cat "$OUT/vtk_$n.log" >&2; exit 1; }
        line=$(grep '^RESULT' "$OUT/vtk_$n.log")
        printf '%s\tvtk-%s\t%s\t%s\n' "$n" "$MAPPER" \
            "$(sed -n 's/.* median_ms=\([^ ]*\).*/\1/p' <<<"$line")" \
            "$(sed -n 's/.* min_ms=\([^ ]*\).*/\1/p' <<<"$line")" >> "$results"
        "$UDVR" --threads "$THREADS" render "$raw" --dims "$n" --spacing "$sp" \
            --origin -2.5,-2.5,-2.5 --tf "$OUT/data/tangle_tf.json" --model "$MODEL" \
            --size "${SIZE}x${SIZE}" --azimuth 30 --elevation 20 --view-angle 30 --step "$sd" \
            --unit-distance "$UNIT" --frames "$FRAMES" -o "$OUT/udvr_$n.png" \
            > "$OUT/udvr_$n.log" 2>&1 || { cat "$OUT/udvr_$n.log" >&2; exit 1; }
        line=$(grep '^RESULT' "$OUT/udvr_$n.log")
        printf '%s\tudvr-%s\t%s\t%s\n' "$n" "$MODEL" \
            "$(sed -n 's/.* median_ms=\([^ ]*\).*/\1/p' <<<"$line")" \
            "$(sed -n 's/.* min_ms=\([^ ]*\).*/\1/p' <<<"$line")" >> "$results"
    done
    "$UDVR" compare "$OUT/udvr_$n.png" "$OUT/vtk_$n.png" --diff "$OUT/diff_$n.png" \
        > "$OUT/rmse_$n.txt"
done

echo "threads $THREADS, image ${SIZE}x${SIZE}, $FRAMES frames after 1 warm-up, $ROUNDS alternating rounds"
"$PY" - "$results" "$OUT" "$NS" <<'PYEOF'
import statistics, sys
rows = [l.rstrip("\n").split("\t") for l in open(sys.argv[1]) if l.strip()]
out, ns = sys.argv[2], sys.argv[3].split()
print("| volume | renderer | median ms per round | median of rounds, ms | min ms | fps | VTK / udvr (median, min) | RMSE udvr vs VTK |")
print("|---|---|---|---|---|---|---|---|")
for n in ns:
    per = {}
    for vol, who, med, mn in rows:
        if vol == n:
            per.setdefault(who, []).append((float(med), float(mn)))
    vtk = next(v for k, v in per.items() if k.startswith("vtk"))
    vmed = statistics.median(m for m, _ in vtk); vmin = min(m for _, m in vtk)
    rmse = open("%s/rmse_%s.txt" % (out, n)).read().strip()
    for who, v in per.items():
        med = statistics.median(m for m, _ in v); mn = min(m for _, m in v)
        ratio = "" if who.startswith("vtk") else "%.2f×, %.2f×" % (vmed / med, vmin / mn)
        print("| %s³ | %s | %s | %.1f | %.1f | %.2f | %s | %s |" % (
            n, who, " / ".join("%.0f" % m for m, _ in v), med, mn, 1000 / med, ratio,
            "" if who.startswith("vtk") else rmse))
PYEOF
