"""Find the built `udvr` module (build/python) and the udvr binary for the tests."""
import os
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
BUILD = pathlib.Path(os.environ.get("UDVR_BUILD_DIR", ROOT / "build"))
if not BUILD.is_absolute():
    BUILD = ROOT / BUILD
sys.path.insert(0, str(BUILD / "python"))


# ---- helpers for the end-to-end CLI tests (test_cli_errors.py) ---------------------------------
import json  # noqa: E402
import struct  # noqa: E402
import subprocess  # noqa: E402

import pytest  # noqa: E402

UDVR_BINARY = pathlib.Path(os.environ.get("UDVR_BINARY", BUILD / "udvr"))
if not UDVR_BINARY.is_absolute():
    UDVR_BINARY = ROOT / UDVR_BINARY


def run_udvr(*args, timeout=60, cwd=None):
    """Run the udvr binary with progress bars off; return the CompletedProcess (text mode)."""
    env = dict(os.environ, UDVR_NO_PROGRESS="1")
    return subprocess.run(
        [str(UDVR_BINARY), *[str(a) for a in args]],
        capture_output=True,
        text=True,
        timeout=timeout,
        env=env,
        cwd=cwd,
        stdin=subprocess.DEVNULL,
    )


def run_ok(*args, **kw):
    """Run udvr and fail the test (with its stderr) unless it exits 0."""
    r = run_udvr(*args, **kw)
    assert r.returncode == 0, f"udvr {' '.join(map(str, args))} failed:\n{r.stderr}"
    return r


def assert_one_line_error(result, *mentions):
    """Non-zero exit; stderr is one non-empty line 'udvr: error: …' naming each of `mentions`."""
    err = result.stderr
    assert result.returncode != 0, f"expected failure, got exit 0; stderr:\n{err}"
    lines = err.splitlines()
    assert len(lines) == 1 and err.endswith("\n"), f"expected one stderr line, got:\n{err}"
    line = lines[0]
    assert line.startswith("udvr: error: ") and len(line) > len("udvr: error: "), line
    for m in mentions:
        assert str(m).lower() in line.lower(), f"{m!r} not mentioned in: {line}"
    return line


def listing(directory):
    """Every file and folder under `directory` (hidden ones too), as relative paths."""
    directory = pathlib.Path(directory)
    return sorted(str(p.relative_to(directory)) for p in directory.rglob("*"))


def write_nrrd(path, values, dims, header_extra=(), type_name="float", fmt="<f", sizes=None):
    """A NRRD with attached raw data: `values` in x-fastest order, little-endian."""
    x, y, z = dims
    lines = ["NRRD0004", f"type: {type_name}", "dimension: 3",
             "sizes: " + (sizes if sizes is not None else f"{x} {y} {z}"),
             "encoding: raw", "endian: little", *header_extra]
    data = b"".join(struct.pack(fmt, v) for v in values)
    pathlib.Path(path).write_bytes(("\n".join(lines) + "\n\n").encode() + data)
    return pathlib.Path(path)


def write_tf(path, rgb_points=None, points=None, raw=None):
    """A ParaView transfer-function JSON (or `raw` text as is)."""
    if raw is None:
        rgb_points = rgb_points if rgb_points is not None else [0, 0, 0, 1, 1, 1, 0, 0]
        points = points if points is not None else [0, 0, 0.5, 0, 1, 0.8, 0.5, 0]
        raw = json.dumps([{"Name": "test", "RGBPoints": rgb_points, "Points": points}])
    pathlib.Path(path).write_text(raw)
    return pathlib.Path(path)


def truncated_copy(src, dst, keep=0.6):
    """Copy `src` to `dst` keeping the first `keep` fraction of its bytes."""
    data = pathlib.Path(src).read_bytes()
    pathlib.Path(dst).write_bytes(data[: int(len(data) * keep)])
    return pathlib.Path(dst)


class Pipeline:
    """Good files from one small run of the whole CLI, shared by the tests (read-only)."""


@pytest.fixture(scope="session")
def udvr_binary():
    if not UDVR_BINARY.is_file():
        pytest.skip(f"udvr binary not built at {UDVR_BINARY} (set UDVR_BINARY or UDVR_BUILD_DIR)")
    return UDVR_BINARY


@pytest.fixture(scope="session")
def pipeline(udvr_binary, tmp_path_factory):
    """generate 16³ → perturb 5 members → build → render; every file a test may start from."""
    d = tmp_path_factory.mktemp("pipeline")
    p = Pipeline()
    p.dir = d
    p.field = d / "field.vti"
    p.field_nc = d / "field.nc"
    p.ensemble = d / "ensemble.nc"
    p.model = d / "model.vti"
    p.model_noq = d / "model_noq.vti"
    p.tf = write_tf(d / "tf.json", [-10, 0, 0, 1, 10, 1, 0.5, 0, 30, 1, 1, 0],
                    [-10, 0, 0.5, 0, 5, 0.3, 0.5, 0, 30, 0.9, 0.5, 0])
    p.model_q6 = d / "model_q6.vti"
    p.png = d / "img.png"
    p.npy = d / "img.npy"
    p.png_small = d / "small.png"
    run_ok("generate", "tangle", "--dims", "16", "-o", p.field)
    run_ok("generate", "tangle", "--dims", "16", "-o", p.field_nc)
    run_ok("perturb", p.field, "--members", "5", "--seed", "3", "-o", p.ensemble)
    run_ok("build", p.ensemble, "--gmm", "2", "-o", p.model)
    run_ok("build", p.ensemble, "--quantiles", "0", "--gmm", "0", "-o", p.model_noq)
    run_ok("build", p.ensemble, "--quantiles", "6", "--gmm", "0", "-o", p.model_q6)
    run_ok("render", p.model, "--model", "gaussian", "--tf", p.tf, "--size", "32x32",
           "--float", p.npy, "-o", p.png)
    run_ok("render", p.model, "--tf", p.tf, "--size", "16x16", "-o", p.png_small)
    p.nrrd = write_nrrd(d / "good.nrrd", [float(i) for i in range(4 * 4 * 4)], (4, 4, 4))
    return p
