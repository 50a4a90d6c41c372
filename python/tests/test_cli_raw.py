"""Headerless raw inputs through the CLI (--dims/--type/--spacing/--origin), against NumPy."""
import os
import pathlib
import subprocess

import numpy as np
import pytest

udvr = pytest.importorskip("udvr")
BIN = os.environ.get("UDVR_BINARY", str(pathlib.Path(__file__).resolve().parents[2] / "build/udvr"))


def run(*args):
    p = subprocess.run([BIN, *map(str, args)], capture_output=True, text=True,
                       env={**os.environ, "UDVR_NO_PROGRESS": "1"})
    assert p.returncode == 0, p.stderr
    return p


def test_build_downsamples_a_big_endian_raw_field(tmp_path):
    rng = np.random.default_rng(5)
    vol = rng.normal(size=(6, 8, 10)).astype(">f4")  # (z, y, x), big-endian
    (tmp_path / "f.raw").write_bytes(vol.tobytes())
    run("build", tmp_path / "f.raw", "--dims", "10,8,6", "--type", "float32", "--big-endian",
        "--spacing", "0.5,1,2", "--origin", "1,2,3", "--downsample", "2", "--gmm", "0",
        "-o", tmp_path / "m.vti")
    m = udvr.read_model(str(tmp_path / "m.vti"))
    bricks = vol.astype(np.float64).reshape(3, 2, 4, 2, 5, 2).transpose(0, 2, 4, 1, 3, 5)
    bricks = bricks.reshape(3, 4, 5, 8)
    np.testing.assert_allclose(m.array("mean"), bricks.mean(-1), rtol=0, atol=1e-5)
    np.testing.assert_allclose(m.array("stddev"), bricks.std(-1, ddof=1), rtol=0, atol=1e-5)
    # SPEC §2: reduced voxel at the brick centre, spacing k·spacing.
    assert m.grid.origin == pytest.approx([1.25, 2.5, 4.0])
    assert m.grid.spacing == pytest.approx([1.0, 2.0, 4.0])


def test_perturb_reads_a_raw_uint8_field(tmp_path):
    vol = np.arange(4 * 3 * 2, dtype=np.uint8).reshape(2, 3, 4)
    (tmp_path / "f.raw").write_bytes(vol.tobytes())
    run("perturb", tmp_path / "f.raw", "--dims", "4,3,2", "--type", "uint8", "--members", "3",
        "--noise", "uniform", "--width", "0", "-o", tmp_path / "e.nc")
    e = udvr.read_ensemble([str(tmp_path / "e.nc")])
    assert e.members == 3
    for m in range(3):
        np.testing.assert_array_equal(e.values[m], vol.astype(np.float32))
