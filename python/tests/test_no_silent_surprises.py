"""No silent surprises (issue 35): members whose arrays are named differently are refused
naming both (--var picks one); `build` says the model's size before writing and the size on
disk after, writes LZ4 (VTK's reader reads it back) or raw with --no-compress; a misspelt
name gets the nearest suggested; `compare --diff` carries a colour scale."""
import os
import re

import numpy as np
import pytest

from conftest import assert_one_line_error, run_ok, run_udvr

udvr = pytest.importorskip("udvr")
pytestmark = pytest.mark.usefixtures("udvr_binary")


def members(tmp_path, names):
    rng = np.random.default_rng(7)
    for i, name in enumerate(names):
        udvr.write_field(str(tmp_path / f"m_{i}.vti"),
                         udvr.Field(rng.uniform(0, 1, (4, 5, 6)).astype(np.float32), name=name))


def test_members_with_differently_named_arrays_are_refused(tmp_path):
    members(tmp_path, ["density", "density", "ImageFile"])
    pattern = str(tmp_path / "m_*.vti")
    for args in (["build", pattern, "--gmm", "0", "-o", tmp_path / "m.vti"],
                 ["build", pattern, "--gmm", "0", "--slab-height", "2", "-o", tmp_path / "m.vti"],
                 ["render", pattern, "--model", "members", "-o", tmp_path / "x.png"]):
        assert_one_line_error(run_udvr(*args), "'ImageFile'", "'density'", "m_2.vti", "--var")
    assert not (tmp_path / "m.vti").exists() and not (tmp_path / "x.png").exists()
    with pytest.raises(ValueError, match="ImageFile"):
        udvr.read_ensemble([pattern])
    # The same name in every member: built as before.
    members(tmp_path, ["density"] * 3)
    run_ok("build", pattern, "--gmm", "0", "-o", tmp_path / "m.vti")


def test_build_says_the_size_and_compresses_unless_told(tmp_path):
    f = udvr.generate("tangle", [24, 20, 16])
    udvr.write_field(str(tmp_path / "f.vti"), f)
    out = {}
    arrays = 12 * 10 * 8 * 27 * 4  # 12x10x8 voxels x (4 + 9 quantiles + 2 iqr + 12 gmm) floats
    for tag, extra in (("lz4", []), ("raw", ["--no-compress"])):
        path = tmp_path / f"{tag}.vti"
        err = run_ok("build", tmp_path / "f.vti", "--downsample", "2", *extra, "-o", path).stderr
        assert "the model:" not in err  # small: no announcement (a failed write stays one line)
        disk = os.path.getsize(path)
        m = re.search(r"\(([\d.]+) KiB on disk, (\d+) % of the ([\d.]+) KiB of arrays\)", err)
        assert m, err
        assert abs(float(m.group(1)) * 1024 - disk) <= 0.005 * disk
        assert abs(float(m.group(3)) * 1024 - arrays) <= 0.005 * arrays
        assert abs(int(m.group(2)) - 100 * disk / arrays) <= 1
        out[tag] = (disk, udvr.load(str(path)))
    assert out["raw"][0] >= arrays > out["lz4"][0]
    for name in ("mean", "stddev", "quantiles", "gmm"):
        assert np.array_equal(getattr(out["raw"][1], name), getattr(out["lz4"][1], name))
    vtk = pytest.importorskip("vtk")
    from vtk.util.numpy_support import vtk_to_numpy
    for tag in ("lz4", "raw"):  # what ParaView's reader makes of either file
        r = vtk.vtkXMLImageDataReader()
        r.SetFileName(str(tmp_path / f"{tag}.vti"))
        r.Update()
        got = vtk_to_numpy(r.GetOutput().GetPointData().GetArray("quantiles"))
        assert np.array_equal(got.reshape(8, 10, 12, 9), out["lz4"][1].quantiles)
    assert_one_line_error(run_udvr("build", tmp_path / "f.vti", "--downsample", "2",
                                   "--no-compress", "--slab-height", "2", "-o",
                                   tmp_path / "s.vti"), "--no-compress", "out of core")


def test_build_announces_a_large_model_before_writing_it(tmp_path):
    udvr.write_field(str(tmp_path / "big.vti"), udvr.generate("tangle", [192, 192, 96]))
    err = run_ok("build", tmp_path / "big.vti", "--downsample", "2", "-o",
                 tmp_path / "m.vti", timeout=300).stderr
    arrays = 96 * 96 * 48 * 27 * 4  # 45.6 MiB: over the 32 MiB that are announced
    m = re.search(r"build: the model: 96x96x48 voxels x 27 floats = ([\d.]+) MiB uncompressed; "
                  r"writing it LZ4-compressed", err)
    assert m and abs(float(m.group(1)) * 2 ** 20 - arrays) <= 0.005 * arrays, err
    assert err.index("the model:") < err.index("-> " + str(tmp_path / "m.vti"))


@pytest.mark.parametrize("args, near", [
    (["render", "X.vti", "--model", "Gaussian", "-o", "x.png"], "'gaussian'"),
    (["render", "X.vti", "--model", "quantile_range", "-o", "x.png"], "'quantile-range'"),
    (["render", "X.vti", "--tf", "Viridis", "-o", "x.png"], "'viridis'"),
    (["render", "X.vti", "--azimth", "3", "-o", "x.png"], "'--azimuth'"),
    (["rendr", "X.vti"], "'render'"),
    (["generate", "tangel", "-o", "x.vti"], "'tangle'"),
    (["perturb", "X.vti", "--noise", "bimodel", "-o", "x.nc"], "'bimodal'"),
])
def test_a_misspelt_name_gets_the_nearest(tmp_path, args, near):
    udvr.write_field(str(tmp_path / "X.vti"), udvr.generate("tangle", [8, 8, 8]))
    line = assert_one_line_error(run_udvr(*args, cwd=tmp_path), "did you mean " + near)
    assert line.count("did you mean") == 1
    # Far from every name: no suggestion.
    assert "did you mean" not in run_udvr("render", "X.vti", "--model", "zzzzzz", "-o", "x.png",
                                          cwd=tmp_path).stderr
    with pytest.raises(TypeError, match="did you mean 'elevation'"):
        udvr.render(udvr.generate("tangle", [8, 8, 8]), "mean", None, 16, elevaton=3)


def test_the_difference_image_carries_its_scale(tmp_path):
    f = udvr.generate("tangle", [20, 20, 20])
    udvr.write_field(str(tmp_path / "f.vti"), f)
    run_ok("render", tmp_path / "f.vti", "--size", "64x48", "--float", tmp_path / "a.npy", "-o",
           tmp_path / "a.png")
    run_ok("render", tmp_path / "f.vti", "--size", "64x48", "--azimuth", "40", "--float",
           tmp_path / "b.npy", "-o", tmp_path / "b.png")
    run_ok("compare", tmp_path / "a.npy", tmp_path / "b.npy", "--diff", tmp_path / "d.png")
    d = udvr.read_image(str(tmp_path / "d.png"))
    assert d.shape[:2] == (64, 64 + 72)  # at least 64 rows: the scale's labels fit
    want = udvr.difference_image(np.load(tmp_path / "a.npy"), np.load(tmp_path / "b.npy"))
    assert np.abs(d[:48, :64, :3] - want[..., :3]).max() <= 1 / 255 + 1e-6
    bar = d[20:56, 64 + 8 + 6, :3]  # the bar's middle column, top to bottom
    assert bar[0, 2] < 0.5 and bar[0, 0] > 0.8  # yellow at the top
    assert bar[-1, 2] > 0.6 and bar[-1, 0] < 0.5  # blue at the bottom
