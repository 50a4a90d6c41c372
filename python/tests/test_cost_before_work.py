"""Cost before work (issue 35): `render` estimates a frame's time from short probes of the same
model, TF and camera at a fraction of the size; over 10 s it says so in one line first, with
what would shorten it; progress lines with the time left are printed even when stderr is not a
terminal (every UDVR_PROGRESS_EVERY seconds, default 10), and UDVR_NO_PROGRESS=1 keeps them
quiet."""
import os
import pathlib
import re
import subprocess
import time

import pytest

from conftest import UDVR_BINARY, run_ok

udvr = pytest.importorskip("udvr")
pytestmark = pytest.mark.usefixtures("udvr_binary")
TF2 = pathlib.Path(__file__).resolve().parents[2] / "data" / "tf2" / "tangle.json"


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    t = tmp_path_factory.mktemp("cost")
    e = udvr.perturb(udvr.generate("tangle", [32, 32, 32]), members=8, seed=3)
    udvr.write_ensemble(str(t / "e.nc"), e)
    run_ok("build", t / "e.nc", "--gmm", "0", "-o", t / "m.vti")
    return t / "m.vti"


def start(args, env_extra, tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "UDVR_NO_PROGRESS"}
    env.update(env_extra)
    return subprocess.Popen([str(UDVR_BINARY), *map(str, args), "-o", str(tmp_path / "x.png")],
                            stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
                            env=env)


def test_a_long_frame_is_announced_before_it_starts(model, tmp_path):
    # The 2D TF over the exact Gaussian kernel: seconds per few pixels (a 2D integral per
    # sample; the fast `gaussian` takes about a second for this frame since issue 33).
    # 64²: 2x2 probes (since main's 2D kernels, an 8x8 probe took 13.5 s at a load of 12).
    p = start(["render", model, "--model", "gaussian-exact", "--tf2", TF2, "--size", "64"],
              {"UDVR_NO_PROGRESS": "1"}, tmp_path)
    try:
        t0 = time.monotonic()
        line = p.stderr.readline()
        waited = time.monotonic() - t0
    finally:
        p.kill()
        p.wait()
    m = re.match(r"render: this frame will take about (\d+) s \(probes of it up to (\d+)x(\d+) "
                 r"took ([\d.]+) s\); shorter: --size (\d+)x(\d+) \(about 10 s\), a quantile "
                 r"model", line)
    assert m, line
    estimate, probe = float(m.group(1)), float(m.group(4))
    assert estimate > 10 and probe < 5 and waited < 30, (line, waited)
    # The suggested size is the one where pixel-proportional time would be 10 s (8 at least).
    side = int(m.group(5))
    assert side == max(8, int(64 * (10 / estimate) ** 0.5)) or \
        estimate * side * side / 64 ** 2 == pytest.approx(10, rel=0.15), (side, estimate)
    assert not (tmp_path / "x.png").exists()


def test_the_estimate_is_near_the_frame_time(model, tmp_path):
    # 128²: since main's kernel names, uniform 256² takes ~10 s here (then it is announced).
    r = run_ok("render", model, "--model", "uniform", "--size", "128", "-o", tmp_path / "u.png")
    m = re.search(r"render: uniform 128x128 in ([\d.]+) ms \(estimated (\d+) ms\)", r.stderr)
    assert m, r.stderr
    actual, estimate = float(m.group(1)), float(m.group(2))
    assert "will take" not in r.stderr
    assert actual / 4 <= estimate <= actual * 4, (actual, estimate)


def test_progress_lines_without_a_terminal(model, tmp_path):
    run_ok("build", model.parent / "e.nc", "--gmm", "2", "-o", tmp_path / "g.vti")
    # gmm-mc advances once per realization: lines at 0.2 s intervals over ~2 s of work.
    args = ["render", tmp_path / "g.vti", "--model", "gmm-mc", "--realizations", "400",
            "--size", "16"]
    p = start(args, {"UDVR_PROGRESS_EVERY": "0.2"}, tmp_path)
    _, err = p.communicate(timeout=300)
    assert p.returncode == 0, err
    lines = re.findall(r"^gmm-mc: (\d+) % done after (\d+) s, about (\d+) s left$", err, re.M)
    assert lines, err
    assert all(0 <= int(d) < 100 for d, _, _ in lines)
    p = start(args, {"UDVR_PROGRESS_EVERY": "0.2", "UDVR_NO_PROGRESS": "1"}, tmp_path)
    _, err = p.communicate(timeout=300)
    assert p.returncode == 0 and "% done after" not in err, err
