#!/usr/bin/env python3
"""Issue 33's 1D target: the `uniform` frame against quantile-mean(8) at 512², as ratios in one run.

The model: the 64³ tangle, 20 members of the default bimodal noise (seed 1), q = 8. Each round
renders both models (the order reversed every other round) with every binary given, and prints
per frame
  - CPU ms: the process's user + system time with 1 + N frames minus that with 1 frame, over N
    (one thread; the model's read and the warm-up frame cancel), which a loaded host inflates far
    less than the wall clock;
  - wall ms: the CLI's own median of N frames after a warm-up (`--frames`, THREADS threads);
then the ratio uniform / quantile-mean of each, the load average, the medians over the rounds and,
with two binaries, each model's time of the first over the second (a speedup below 1).

  bench/uniform_ratio.py                                   # build/udvr, data/tf/tangle.json
  TF=default bench/uniform_ratio.py                        # the default preset (cool-to-warm)
  ROUNDS=7 bench/uniform_ratio.py build/udvr /path/to/base/udvr
Environment: ROUNDS (5), FRAMES (3), THREADS (wall timing; 2), SIZE (512), TF (a file or
`default`), MODELS ("quantile-mean uniform": the first is the denominator), WORK
(/tmp/udvr-uniform-ratio).
"""
import os
import resource
import statistics
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ROUNDS = int(os.environ.get("ROUNDS", "5"))
FRAMES = int(os.environ.get("FRAMES", "3"))
THREADS = os.environ.get("THREADS", "2")
SIZE = os.environ.get("SIZE", "512")
TF = os.environ.get("TF", os.path.join(ROOT, "data", "tf", "tangle.json"))
MODELS = os.environ.get("MODELS", "quantile-mean uniform").split()
WORK = os.environ.get("WORK", "/tmp/udvr-uniform-ratio")
BINS = [os.path.abspath(b) for b in sys.argv[1:]] or [os.path.join(ROOT, "build", "udvr")]
ENV = dict(os.environ, UDVR_NO_PROGRESS="1")


def run(args):
    return subprocess.run(args, env=ENV, check=True, capture_output=True, text=True).stdout


def model():
    m = os.path.join(WORK, "model.vti")
    if not os.path.exists(m):
        os.makedirs(WORK, exist_ok=True)
        t, e = os.path.join(WORK, "tangle.vti"), os.path.join(WORK, "ens.nc")
        run([BINS[0], "generate", "tangle", "--dims", "64", "-o", t])
        run([BINS[0], "perturb", t, "--members", "20", "--seed", "1", "-o", e])
        run([BINS[0], "build", e, "--quantiles", "8", "-o", m])
    return m


def render(binary, m, name, frames, threads):
    args = [binary, "render", m, "--model", name, "--size", f"{SIZE}x{SIZE}", "--frames",
            str(frames), "--threads", str(threads), "-o", os.path.join(WORK, "frame.png")]
    if TF != "default":
        args += ["--tf", TF]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = run(args)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime) * 1000.0
    wall = float(out.split("median_ms=")[1].split()[0])
    return cpu, wall


def main():
    m = model()
    cpu, wall = {}, {}
    for r in range(ROUNDS):
        order = [(b, n) for b in BINS for n in MODELS]
        if r % 2:
            order.reverse()
        load = os.getloadavg()[0]
        for b, n in order:
            c1, _ = render(b, m, n, 1, 1)
            cn, _ = render(b, m, n, 1 + FRAMES, 1)
            _, w = render(b, m, n, FRAMES, THREADS)
            cpu.setdefault((b, n), []).append((cn - c1) / FRAMES)
            wall.setdefault((b, n), []).append(w)
        line = f"round {r + 1} load {load:.2f}:"
        for i, b in enumerate(BINS):
            c = [cpu[(b, n)][-1] for n in MODELS]
            w = [wall[(b, n)][-1] for n in MODELS]
            line += (f"  [{i}] CPU " + " ".join(f"{x:.0f}" for x in c) + f" ({c[-1] / c[0]:.2f}x)"
                     f" wall " + " ".join(f"{x:.0f}" for x in w) + f" ({w[-1] / w[0]:.2f}x)")
        print(line, flush=True)
    print(f"medians over {ROUNDS} rounds ({' / '.join(reversed(MODELS))}; ms):")
    for i, b in enumerate(BINS):
        for what, d in (("CPU", cpu), (f"wall ({THREADS} threads)", wall)):
            ratios = [u / q for u, q in zip(d[(b, MODELS[-1])], d[(b, MODELS[0])])]
            print(f"  [{i}] {b} {what}: " +
                  ", ".join(f"{n} {statistics.median(d[(b, n)]):.0f}" for n in MODELS) +
                  f"; ratio {statistics.median(ratios):.2f} ({min(ratios):.2f}-{max(ratios):.2f})")
    if len(BINS) == 2:
        for n in MODELS:
            s = [x / y for x, y in zip(cpu[(BINS[0], n)], cpu[(BINS[1], n)])]
            print(f"  {n}: CPU [0]/[1] {statistics.median(s):.3f} ({min(s):.3f}-{max(s):.3f})")


if __name__ == "__main__":
    main()
