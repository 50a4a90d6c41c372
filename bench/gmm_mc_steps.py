#!/usr/bin/env python3
"""serve's progressive steps for gmm-mc (issue 35): a coarse step can cut the pixels (the side
halved, all realizations) or the realizations (the full side, 1/4 of them). For each, the
frame's time and its RMSE against the full frame (512², 200 realizations) as the page shows it
(the coarse image stretched to the full size, bilinear as the browser's canvas scaling).

  /usr/bin/python3 bench/gmm_mc_steps.py MODEL.vti [--udvr build/udvr] [--size 512]
"""
import argparse
import os
import re
import subprocess
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

ROOT = Path(__file__).resolve().parent.parent
LINE = re.compile(r"in ([\d.]+) ms \(estimated (\d+) ms\)")


def render(udvr, model, size, realizations, out):
    r = subprocess.run([udvr, "render", model, "--model", "gmm-mc", "--size", str(size),
                        "--realizations", str(realizations), "-o", out],
                       capture_output=True, text=True,
                       env=dict(os.environ, UDVR_NO_PROGRESS="1"))
    if r.returncode:
        raise SystemExit(r.stderr)
    return float(LINE.search(r.stderr).group(1))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("model")
    ap.add_argument("--udvr", default=str(ROOT / "build" / "udvr"))
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--realizations", type=int, default=200)
    a = ap.parse_args()
    n, r0 = a.size, a.realizations
    with tempfile.TemporaryDirectory() as d:
        full = Path(d) / "full.png"
        t_full = render(a.udvr, a.model, n, r0, full)
        ref = np.asarray(Image.open(full).convert("RGB"), dtype=np.float64) / 255
        print(f"load {open('/proc/loadavg').read().split()[0]}; full {n}² {r0} realizations: "
              f"{t_full:.0f} ms")
        rows = [(n >> k, r0, f"side/{1 << k}") for k in (1, 2, 3)]
        rows += [(n, r0 >> (2 * k), f"realizations/{1 << (2 * k)}") for k in (1, 2, 3)
                 if r0 >> (2 * k) >= 2]
        for size, r, what in rows:
            out = Path(d) / f"s{size}_r{r}.png"
            t = render(a.udvr, a.model, size, r, out)
            img = Image.open(out).convert("RGB")
            if size != n:
                img = img.resize((n, n), Image.BILINEAR)
            x = np.asarray(img, dtype=np.float64) / 255
            rmse = float(np.sqrt(np.mean((x - ref) ** 2)))
            print(f"{what:18} {size:4}² {r:4} realizations: {t:8.0f} ms "
                  f"({t / t_full:.2f} of the full frame), RMSE {rmse:.4f}")


if __name__ == "__main__":
    main()
