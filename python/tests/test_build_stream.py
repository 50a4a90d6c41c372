"""Out-of-core `udvr build` (issue 15): slabs of z-planes give the in-memory model file byte for
byte, for NetCDF ensembles, member files of each format and --downsample bricks; slab heights
that do not divide the grid (1, 7), the whole grid, and a slab larger than the grid."""
import os
import signal
import subprocess
import time

import numpy as np
import pytest

from conftest import UDVR_BINARY, assert_one_line_error, run_ok, run_udvr, write_nrrd

DIMS = (13, 11, 23)  # x, y, z: 23 planes, divided by neither 7 nor 2


def build(*args):
    """Run build; return stderr (the summary lines)."""
    return run_ok("build", *args, timeout=180).stderr


def same_bytes(a, b):
    return a.read_bytes() == b.read_bytes()


@pytest.fixture(scope="module")
def nc_ensemble(tmp_path_factory):
    d = tmp_path_factory.mktemp("nc")
    run_ok("generate", "tangle", "--dims", ",".join(map(str, DIMS)), "-o", d / "f.vti")
    run_ok("perturb", d / "f.vti", "--members", "9", "--noise", "bimodal", "--seed", "5",
           "-o", d / "e.nc")
    return d / "e.nc"


@pytest.fixture(scope="module")
def raw_members(tmp_path_factory):
    """7 float32 members with random values, some constant voxels and two NaNs in member 2."""
    d = tmp_path_factory.mktemp("raw")
    rng = np.random.default_rng(3)
    x, y, z = DIMS
    truth = np.sin(np.arange(x * y * z) * 0.01).reshape(z, y, x)
    files = []
    for m in range(7):
        v = truth + np.where(rng.random(truth.shape) < 0.7, 0.3 * rng.standard_normal(truth.shape),
                             1.5 + 0.5 * rng.standard_normal(truth.shape))
        v.reshape(-1)[::17] = truth.reshape(-1)[::17]  # constant voxels
        v = v.astype("<f4")
        if m == 2:
            v.reshape(-1)[[40, 2000]] = np.nan
        p = d / f"m_{m}.raw"
        v.tofile(p)
        files.append(p)
    return files


RAW = ("--dims", ",".join(map(str, DIMS)), "--type", "float32")


@pytest.mark.parametrize("extra", [(), ("--density", "kde", "--quantiles", "5", "--gmm", "3")])
def test_netcdf_ensemble_slabs_are_bit_identical(nc_ensemble, tmp_path, extra):
    ref = tmp_path / "ref.vti"
    err = build(nc_ensemble, *extra, "-o", ref)
    assert "out of core" not in err
    for h in (1, 7, 23, 100):
        out = tmp_path / f"s{h}.vti"
        err = build(nc_ensemble, *extra, "--slab-height", h, "-o", out)
        slabs = -(-23 // min(h, 23))
        assert f"out of core: {slabs} slab" in err, err
        assert "in memory (limit" in err and "the input read twice" in err, err
        assert same_bytes(ref, out), f"--slab-height {h} differs from the in-memory build"


def test_raw_member_slabs_are_bit_identical_with_nan_skip(raw_members, tmp_path):
    ref = tmp_path / "ref.vti"
    build(*raw_members, *RAW, "--nan", "skip", "-o", ref)
    for h in (1, 7, 23):
        out = tmp_path / f"s{h}.vti"
        build(*raw_members, *RAW, "--nan", "skip", "--slab-height", h, "-o", out)
        assert same_bytes(ref, out), h
    # --nan error: one line naming the first voxel and member, as in memory.
    r_mem = run_udvr("build", *raw_members, *RAW, "-o", tmp_path / "x.vti")
    r_slab = run_udvr("build", *raw_members, *RAW, "--slab-height", "7", "-o", tmp_path / "x.vti")
    assert_one_line_error(r_slab, "NaN", "member 2")
    assert r_mem.returncode != 0
    assert not (tmp_path / "x.vti").exists()


def write_vti(path, values, dims):
    """VTK XML ImageData with an inline ASCII Float32 point array (x fastest)."""
    x, y, z = dims
    text = " ".join(repr(float(v)) for v in values)
    path.write_text(
        '<?xml version="1.0"?>\n<VTKFile type="ImageData" version="1.0" '
        'byte_order="LittleEndian" header_type="UInt64">\n'
        f'<ImageData WholeExtent="0 {x - 1} 0 {y - 1} 0 {z - 1}" Origin="0 0 0" '
        'Spacing="1 1 1">\n'
        f'<Piece Extent="0 {x - 1} 0 {y - 1} 0 {z - 1}"><PointData Scalars="v">\n'
        f'<DataArray type="Float32" Name="v" format="ascii">{text}</DataArray>\n'
        "</PointData></Piece></ImageData></VTKFile>\n")
    return path


def write_nc(path, values, dims, members=None, member_last=False, packed=False):
    """NetCDF-3 (scipy): variable 'v' on z,y,x, or with a member dimension first or last;
    packed: int16 with scale_factor and add_offset (read as double, then unpacked)."""
    netcdf = pytest.importorskip("scipy.io").netcdf_file
    x, y, z = dims
    f = netcdf(str(path), "w")
    if members is None:
        names, shape = ("z", "y", "x"), (z, y, x)
    elif member_last:
        names, shape = ("z", "y", "x", "member"), (z, y, x, members)
    else:
        names, shape = ("member", "z", "y", "x"), (members, z, y, x)
    for name, n in zip(names, shape):
        f.createDimension(name, n)
    v = np.asarray(values, dtype="f8")
    if members is not None:
        v = v.reshape(members, z, y, x)
        if member_last:
            v = np.moveaxis(v, 0, -1)
    v = v.reshape(shape)
    if packed:
        var = f.createVariable("v", "i2", names)
        var.scale_factor = np.float32(0.001)
        var.add_offset = np.float32(1.0)
        var[:] = np.round((v - 1.0) / 0.001).astype("i2")
    else:
        f.createVariable("v", "f4", names)[:] = v.astype("f4")
    f.close()
    return path


def test_vti_nrrd_and_netcdf_member_files(raw_members, tmp_path):
    values = [np.nan_to_num(np.fromfile(p, "<f4")) for p in raw_members[:4]]
    groups = {
        ".vti": [write_vti(tmp_path / f"m{m}.vti", v, DIMS) for m, v in enumerate(values)],
        ".nrrd": [write_nrrd(tmp_path / f"m{m}.nrrd", v.tolist(), DIMS)
                  for m, v in enumerate(values)],
        ".nc": [write_nc(tmp_path / f"m{m}.nc", v, DIMS) for m, v in enumerate(values)],
        "packed.nc": [write_nc(tmp_path / f"p{m}.nc", v, DIMS, packed=True)
                      for m, v in enumerate(values)],
    }
    for ext, files in groups.items():
        ref = tmp_path / f"ref{ext}.vti"
        build(*files, "--gmm", "3", "-o", ref)
        out = tmp_path / f"s{ext}.vti"
        err = build(*files, "--gmm", "3", "--slab-height", "7", "-o", out)
        if ext in (".vti", ".nrrd"):
            assert "read whole for every slab" in err, err
        assert same_bytes(ref, out), ext


@pytest.mark.parametrize("member_last", [False, True])
def test_netcdf_member_dimension_anywhere(raw_members, tmp_path, member_last):
    values = np.concatenate([np.nan_to_num(np.fromfile(p, "<f4")) for p in raw_members])
    nc = write_nc(tmp_path / "e.nc", values, DIMS, members=len(raw_members),
                  member_last=member_last)
    ref = tmp_path / "ref.vti"
    build(nc, "-o", ref)
    for h in (1, 7):
        out = tmp_path / f"s{h}.vti"
        build(nc, "--slab-height", h, "-o", out)
        assert same_bytes(ref, out), h


@pytest.mark.parametrize("fmt", ["vti", "raw"])
def test_downsample_slabs_are_bit_identical(raw_members, tmp_path, fmt):
    if fmt == "vti":
        field = tmp_path / "f.vti"
        run_ok("generate", "tangle", "--dims", ",".join(map(str, DIMS)), "-o", field)
        args = (field,)
    else:
        field = raw_members[0]
        args = (field, *RAW, "--nan", "skip")
    ref = tmp_path / "ref.vti"
    build(*args, "--downsample", "2", "--gmm", "2", "-o", ref)
    for h in (2, 14, 22, 24, 60):
        out = tmp_path / f"s{h}.vti"
        err = build(*args, "--downsample", "2", "--gmm", "2", "--slab-height", h, "-o", out)
        assert "left out the trailing 1,1,1 planes" in err
        assert same_bytes(ref, out), h
    assert_one_line_error(
        run_udvr("build", *args, "--downsample", "2", "--slab-height", "7", "-o", ref),
        "--slab-height 7", "multiple of --downsample 2")


def test_memory_limit_streams_when_the_build_does_not_fit(tmp_path):
    # 100 members of 64x64 values: 1.6 MiB of input per z-plane, 10 planes.
    run_ok("generate", "tangle", "--dims", "64,64,10", "-o", tmp_path / "f.vti")
    run_ok("perturb", tmp_path / "f.vti", "--members", "100", "--seed", "2", "-o",
           tmp_path / "e.nc")
    nc = tmp_path / "e.nc"
    opts = ("--quantiles", "4", "--gmm", "0")
    ref = tmp_path / "ref.vti"
    build(nc, *opts, "-o", ref)
    # Fits in memory: the in-memory build.
    err = build(nc, *opts, "--memory-limit", "4G", "-o", tmp_path / "a.vti")
    assert "out of core" not in err
    assert same_bytes(ref, tmp_path / "a.vti")
    # Too small for one z-plane: the error says what one needs; 4 MiB more takes 2-3 planes.
    r = run_udvr("build", nc, *opts, "--memory-limit", "1K", "-o", tmp_path / "b.vti")
    line = assert_one_line_error(r, "--memory-limit 1K", "too small", "one z-plane")
    value, unit = line.split("needs about ")[1].split(";")[0].split()
    assert unit == "MiB", line
    err = build(nc, *opts, "--memory-limit", f"{float(value) + 4:.1f}M", "-o", tmp_path / "b.vti")
    plan = [ln for ln in err.splitlines() if "in memory (limit" in ln]
    assert len(plan) == 1 and "slabs of 1 z-plane " not in plan[0], err  # said once, no GMM
    assert "the input read once" in err, err
    assert same_bytes(ref, tmp_path / "b.vti")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.vti", "b.vti", "e.nc", "f.vti",
                                                          "ref.vti"]


@pytest.mark.parametrize("value", ["abc", "0", "-5", "4X", "1.5.2G", "G", ""])
def test_bad_memory_limit_is_a_one_line_error(nc_ensemble, tmp_path, value):
    r = run_udvr("build", nc_ensemble, "--memory-limit", value, "-o", tmp_path / "m.vti")
    assert_one_line_error(r, "--memory-limit")
    assert not (tmp_path / "m.vti").exists()


def test_bad_slab_height_is_a_one_line_error(nc_ensemble, tmp_path):
    r = run_udvr("build", nc_ensemble, "--slab-height", "0", "-o", tmp_path / "m.vti")
    assert_one_line_error(r, "--slab-height 0")


def test_memory_limit_suffixes_are_accepted(nc_ensemble, tmp_path):
    for value in ("512M", "4g", "1.5GiB", "3000000000", "2T", "auto"):
        build(nc_ensemble, "--memory-limit", value, "--quantiles", "0", "--gmm", "0", "-o",
              tmp_path / "m.vti")


def test_killed_out_of_core_build_leaves_nothing(tmp_path):
    """The slabs' spill files are unnamed (O_TMPFILE): kill -9 in the middle of an out-of-core
    build leaves nothing in the output directory."""
    run_ok("generate", "tangle", "--dims", "48,48,30", "-o", tmp_path / "f.vti")
    run_ok("perturb", tmp_path / "f.vti", "--members", "40", "-o", tmp_path / "e.nc")
    out = tmp_path / "out"
    out.mkdir()
    env = dict(os.environ, UDVR_NO_PROGRESS="1")
    p = subprocess.Popen([str(UDVR_BINARY), "build", str(tmp_path / "e.nc"), "--slab-height", "1",
                          "-o", str(out / "m.vti")], stdout=subprocess.DEVNULL,
                         stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL, env=env)
    # Wait until it holds its spill files (unnamed, so only /proc shows them), then kill it.
    deadline = time.monotonic() + 60
    spills = []
    while time.monotonic() < deadline and p.poll() is None and not spills:
        try:
            fds = f"/proc/{p.pid}/fd"
            spills = [os.readlink(f"{fds}/{fd}") for fd in os.listdir(fds)]
        except OSError:
            spills = []
        spills = [s for s in spills if s.startswith(str(out))]
        time.sleep(0.002)
    running = p.poll() is None
    p.send_signal(signal.SIGKILL)
    p.wait(timeout=60)
    assert running and spills, "the build ended before its spill files were seen"
    assert all("(deleted)" in s for s in spills), spills
    assert list(out.iterdir()) == []


@pytest.mark.parametrize("extra", [("--density", "dequantized"),
                                   ("--quantile-levels", "0,0.1,0.5,0.9,1", "--gmm", "2"),
                                   ("--density", "kde", "--bandwidth", "scott", "--tail-eps",
                                    "0.05")])
def test_uint8_members_with_other_estimates(tmp_path, extra):
    rng = np.random.default_rng(9)
    files = []
    for m in range(6):
        p = tmp_path / f"u{m}.raw"
        rng.integers(0, 40, size=DIMS[0] * DIMS[1] * DIMS[2], dtype=np.uint8).tofile(p)
        files.append(p)
    args = (*files, "--dims", ",".join(map(str, DIMS)), "--type", "uint8", *extra)
    build(*args, "-o", tmp_path / "ref.vti")
    for h in (1, 7):
        build(*args, "--slab-height", h, "-o", tmp_path / f"s{h}.vti")
        assert same_bytes(tmp_path / "ref.vti", tmp_path / f"s{h}.vti"), h


def test_out_of_core_pvti_is_a_one_line_error(nc_ensemble, tmp_path):
    r = run_udvr("build", nc_ensemble, "--slab-height", "7", "-o", tmp_path / "m.pvti")
    assert_one_line_error(r, "out of core", ".vti")
    assert list(tmp_path.iterdir()) == []
