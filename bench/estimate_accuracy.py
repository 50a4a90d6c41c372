#!/usr/bin/env python3
"""Frame estimates against the frames (issue 35, cost before work): `udvr render` prints
"render: MODEL WxH in T ms (estimated E ms)"; this runs it for every model of a model volume
built from ../shared/data, with a 1D TF (the default) and a 2D TF, and prints estimate, frame and
their ratio, with the load average. Models are built once into --work.

  python3 bench/estimate_accuracy.py [--udvr build/udvr] [--work /tmp/est] [--size 512]
      [--size2d 128] [--only chest,tooth] [--models mean,uniform]
"""
import argparse
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared" / "data"
MODELS = ["mean", "uniform", "uniform-exact", "gaussian", "gmm-ordered", "gmm-mc",
          "quantile-range", "quantile-mean", "quantile-mean-mass", "iqr"]
LINE = re.compile(r"render: (\S+) (\d+)x(\d+) in ([\d.]+) ms \(estimated (\d+) ms\)")


def load():
    return open("/proc/loadavg").read().split()[0]


def run(cmd, env):
    r = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, env=env)
    if r.returncode:
        raise SystemExit(f"{' '.join(map(str, cmd))}: {r.stderr.strip()}")
    return r.stderr


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--udvr", default=str(ROOT / "build" / "udvr"))
    ap.add_argument("--work", default="/tmp/udvr_estimate_accuracy")
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--size2d", type=int, default=128)
    ap.add_argument("--only", default="chest,tooth,neghip,fuel")
    ap.add_argument("--models", default=",".join(MODELS))
    ap.add_argument("--no-2d", action="store_true")
    a = ap.parse_args()
    work = Path(a.work)
    work.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, UDVR_NO_PROGRESS="1")
    # name: (the build's inputs and flags, a 2D TF or None)
    sets = {
        "chest": ([SHARED / "chest-ct" / "chest.nhdr", "--downsample", "2"], "box"),
        "tooth": ([SHARED / "tooth" / "tooth.nhdr", "--downsample", "2"],
                  ROOT / "data" / "tf2" / "tooth.json"),
        "neghip": ([SHARED / "neghip" / "neghip.nhdr", "--downsample", "2"], "box"),
        "fuel": ([*sorted((SHARED / "fuel-ensemble" / "members").glob("member_*.nhdr"))], "box"),
    }
    print(f"{'data':7} {'TF':3} {'model':19} {'size':>8} {'estimate ms':>12} {'frame ms':>10} "
          f"{'frame/est':>9} load")
    for name in a.only.split(","):
        inputs, tf2 = sets[name]
        model = work / f"{name}.vti"
        if not model.exists():
            run([a.udvr, "build", *inputs, "-o", model, "--gmm", "4"], env)
        tfs = [("1D", [], a.size)]
        if tf2 is not None and not a.no_2d:
            if tf2 == "box":  # a box over the upper 70 % of the values, low gradients
                tf2 = work / f"{name}_box.json"
                if not tf2.exists():
                    r = subprocess.run([a.udvr, "info", str(model), "--json"], capture_output=True,
                                       text=True, env=env)
                    v = json.loads(r.stdout)["values"]
                    lo, hi = v["min"], v["max"]
                    tf2.write_text(json.dumps({"domain": [lo, hi, 0, (hi - lo) / 2],
                                               "widgets": [{"type": "box",
                                                            "x": [lo + 0.3 * (hi - lo), hi],
                                                            "y": [0, (hi - lo) / 4],
                                                            "rgba": [1, 0.5, 0.2, 0.2]}]}))
            tfs.append(("2D", ["--tf2", tf2], a.size2d))
        for tfname, flags, size in tfs:
            for m in a.models.split(","):
                out = work / f"{name}_{tfname}_{m}.png"
                t0 = time.time()
                try:
                    err = run([a.udvr, "render", model, "--model", m, *flags, "--size", size,
                               "-o", out], env)
                except SystemExit as e:
                    print(f"{name:7} {tfname:3} {m:19} skipped: {str(e)[-120:]}")
                    continue
                hit = LINE.search(err)
                est, ms = float(hit.group(5)), float(hit.group(4))
                print(f"{name:7} {tfname:3} {m:19} {size:>4}x{size:<3} {est:12.0f} {ms:10.0f} "
                      f"{ms / est if est else float('nan'):9.2f} {load()}  "
                      f"({time.time() - t0:.1f} s in all)", flush=True)


if __name__ == "__main__":
    sys.exit(main())
