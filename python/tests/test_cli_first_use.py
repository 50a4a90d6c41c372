"""The first five minutes of a new user (issue 11): each slip gets one line on stderr that says
what to do, errors exit non-zero and leave no output behind, and the non-fatal cases (a small
ensemble, --threads after the command) just work with one info or warning line.

Grids are tiny (8³ and smaller) so the file runs in a few seconds; the cases on the real sample
data in ../shared/data skip when it is absent.
"""
import pathlib
import struct

import pytest

from conftest import (
    ROOT,
    assert_one_line_error,
    listing,
    run_ok,
    run_udvr,
    write_nrrd,
    write_tf,
)

pytestmark = pytest.mark.usefixtures("udvr_binary")

SHARED = ROOT.parent / "shared" / "data"
FUEL_NC = SHARED / "fuel-ensemble" / "fuel_ensemble.nc"
FUEL_MEMBERS = SHARED / "fuel-ensemble" / "members"
NEGHIP_RAW = SHARED / "neghip" / "neghip.raw"


def need(path):
    if not pathlib.Path(path).exists():
        pytest.skip(f"sample data {path} is absent")
    return path


def members(t, n, dims=(4, 4, 4)):
    """n NRRD member files on one grid, each voxel's values differing across members."""
    count = dims[0] * dims[1] * dims[2]
    return [write_nrrd(t / f"m{m}.nrrd", [float(i % 7) + 0.5 * m * m for i in range(count)], dims)
            for m in range(n)]


def assert_nothing_left(t, before):
    assert listing(t) == before, "output left behind"


def error_leaves_nothing(t, *args):
    """Run a command that must fail; return its one error line, checking nothing was written."""
    before = listing(t)
    r = run_udvr(*args)
    line = assert_one_line_error(r)
    assert r.stdout == ""
    assert_nothing_left(t, before)
    return line


@pytest.fixture
def small(tmp_path):
    """A tiny field, a 3-member ensemble of it, a model and a TF, in tmp_path."""
    field = tmp_path / "f.vti"
    run_ok("generate", "tangle", "--dims", "8", "-o", field)
    ens = tmp_path / "e.nc"
    run_ok("perturb", field, "--members", "3", "--seed", "2", "-o", ens)
    model = tmp_path / "m.vti"
    run_ok("build", ens, "--gmm", "2", "-o", model)
    tf = write_tf(tmp_path / "tf.json", [-10, 0, 0, 1, 30, 1, 1, 0],
                  [-10, 0, 0.5, 0, 30, 1, 0.5, 0])
    return dict(field=field, ensemble=ens, model=model, tf=tf, dir=tmp_path)


# ---- 1. a small ensemble builds: GMM K and quantiles fitted to the samples per voxel -----------


def test_three_members_build_with_k_lowered_in_one_info_line(tmp_path):
    files = members(tmp_path, 3)
    out = tmp_path / "m.vti"
    r = run_ok("build", *files, "-o", out)
    assert out.is_file()
    lines = r.stderr.splitlines()
    info = [ln for ln in lines if "lowered" in ln]
    assert info == ["build: 3 samples per voxel: GMM K lowered from 4 to 3; the 9 quantile "
                    "boundaries interpolate between only 3 sample values"], r.stderr
    assert not any(ln.startswith("udvr: warning") for ln in lines), r.stderr
    assert "GMM K=3" in r.stderr


def test_two_members_are_enough(tmp_path):
    out = tmp_path / "m.vti"
    r = run_ok("build", *members(tmp_path, 2), "-o", out)
    assert out.is_file()
    assert "GMM K lowered from 4 to 2" in r.stderr


def test_explicit_gmm_and_quantiles_above_the_samples_warn_once_each(tmp_path):
    out = tmp_path / "m.vti"
    r = run_ok("build", *members(tmp_path, 3), "--gmm", "6", "--quantiles", "5", "-o", out)
    assert out.is_file()
    warnings = [ln for ln in r.stderr.splitlines() if ln.startswith("udvr: warning:")]
    assert len(warnings) == 2, r.stderr
    assert "--gmm 6" in warnings[0] and "lowered from 6 to 3" in warnings[0]
    assert "--quantiles 5" in warnings[1] and "only 3 sample values" in warnings[1]
    assert not any(ln.startswith("build: 3 samples") for ln in r.stderr.splitlines())


def test_kde_quantiles_and_enough_samples_say_nothing(tmp_path):
    files = members(tmp_path, 3)
    r = run_ok("build", *files, "--density", "kde", "--gmm", "3", "--quantiles", "8",
               "-o", tmp_path / "m.vti")
    assert "lowered" not in r.stderr and "warning" not in r.stderr, r.stderr


def test_downsample_bricks_lower_k_too(tmp_path):
    field = tmp_path / "f.vti"
    run_ok("generate", "tangle", "--dims", "8", "-o", field)
    r = run_ok("build", field, "--downsample", "2", "--gmm", "12", "--quantiles", "4",
               "-o", tmp_path / "m.vti")
    assert "udvr: warning: --gmm 12 needs at least 12 samples per voxel, the input has 8" \
        in r.stderr
    assert "GMM K=8" in r.stderr


def test_other_build_option_checks_still_fail(small):
    t = small["dir"]
    line = error_leaves_nothing(t, "build", small["ensemble"], "--gmm", "-2", "-o", t / "x.vti")
    assert "--gmm -2" in line
    line = error_leaves_nothing(t, "build", small["ensemble"], "--gmm", "33", "-o", t / "x.vti")
    assert "--gmm 33" in line


def test_fuel_members_build(tmp_path):
    files = sorted(need(FUEL_MEMBERS).glob("member_*.nhdr"))
    if len(files) < 3:
        pytest.skip(f"fewer than 3 member files in {FUEL_MEMBERS}")
    out = tmp_path / "m.vti"
    r = run_ok("build", *files[:3], "--quantiles", "0", "-o", out)
    assert out.is_file() and "GMM K lowered from 4 to 3" in r.stderr


# ---- 2. output formats follow the extension, checked before any work --------------------------


@pytest.mark.parametrize("case", [
    ("perturb", ["--members", "3"], "p.vti", [".nc", "perturb writes a NetCDF ensemble", "p.vti"]),
    ("perturb", ["--members", "3"], "p", [".nc", "'"]),
    ("build", [], "m.nc", [".vti", "build writes a model", "m.nc"]),
    ("build", [], "m.vtk", [".vti", "m.vtk"]),
])
def test_writers_follow_the_extension(small, case):
    cmd, extra, name, mentions = case
    t = small["dir"]
    src = small["field"] if cmd == "perturb" else small["ensemble"]
    before = listing(t)
    r = run_udvr(cmd, src, *extra, "-o", t / name)
    line = assert_one_line_error(r, "-o must name a", *mentions)
    assert "must name a" in line
    assert_nothing_left(t, before)


def test_extension_is_checked_before_the_input_is_read(tmp_path):
    # The input does not exist: the extension error comes first, so nothing is read.
    for args, what in [
        (["perturb", tmp_path / "absent.vti", "-o", tmp_path / "p.vti"], ".nc"),
        (["build", tmp_path / "absent.nc", "-o", tmp_path / "m.nc"], ".vti"),
        (["compare", tmp_path / "a.png", tmp_path / "b.png", "--diff", tmp_path / "d.jpg"],
         ".png"),
    ]:
        line = error_leaves_nothing(tmp_path, *args)
        assert what in line and "absent" not in line and "a.png" not in line, line


def test_generate_checks_the_extension_before_generating(tmp_path):
    line = error_leaves_nothing(tmp_path, "generate", "tangle", "--dims", "4", "-o",
                                tmp_path / "f.png")
    assert ".vti or .nc" in line and "f.png" in line
    # Upper-case extensions are fine.
    run_ok("generate", "tangle", "--dims", "4", "-o", tmp_path / "F.VTI")
    run_ok("generate", "tangle", "--dims", "4", "-o", tmp_path / "f.nc")


def test_render_probe_and_tf2_outputs_are_checked(small):
    t = small["dir"]
    line = error_leaves_nothing(t, "render", small["model"], "--tf", small["tf"], "--size", "8",
                                "-o", t / "i.jpg")
    assert ".png" in line and "i.jpg" in line
    line = error_leaves_nothing(t, "render", small["model"], "--tf", small["tf"], "--size", "8",
                                "--float", t / "i.txt", "-o", t / "i.png")
    assert ".npy" in line and "i.txt" in line
    line = error_leaves_nothing(t, "probe", small["model"], "--point", "1,1,1", "--model", "mean",
                                "--tf", small["tf"], "--plot", t / "p.svg")
    assert ".png" in line and "p.svg" in line
    line = error_leaves_nothing(t, "compare", t / "x.png", t / "y.png", "--diff", t / "d.npy")
    assert "--diff" in line and ".png" in line


def test_perturb_output_builds_back(small):
    t = small["dir"]
    out = t / "m2.vti"
    run_ok("build", small["ensemble"], "--gmm", "0", "-o", out)
    assert out.is_file()


# ---- 3. a raw file whose size fits another layout names it ------------------------------------


def test_raw_uint8_read_as_float_names_the_type(tmp_path):
    raw = tmp_path / "vol.raw"
    raw.write_bytes(bytes(range(64)))  # 4³ uint8
    line = error_leaves_nothing(tmp_path, "render", raw, "--dims", "4", "-o", tmp_path / "i.png")
    for m in ["vol.raw", "size 64 bytes", "fits uint8 4x4x4", "--type uint8"]:
        assert m in line, line
    # ... and with the suggested type it renders.
    run_ok("render", raw, "--dims", "4", "--type", "uint8", "--size", "8", "-o",
           tmp_path / "i.png")


def test_raw_with_wrong_dims_names_cubic_dims(tmp_path):
    raw = tmp_path / "vol.raw"
    raw.write_bytes(struct.pack("<27f", *range(27)))  # 3³ float32
    line = error_leaves_nothing(tmp_path, "perturb", raw, "--dims", "4", "-o", tmp_path / "e.nc")
    assert "fits float32 3x3x3" in line and "--dims 3" in line, line


def test_raw_size_that_fits_nothing_says_truncated(tmp_path):
    raw = tmp_path / "vol.raw"
    raw.write_bytes(b"\0" * 90)
    line = error_leaves_nothing(tmp_path, "perturb", raw, "--dims", "4,3,2", "-o",
                                tmp_path / "e.nc")
    assert "truncated" in line and "expected 96 bytes" in line, line


def test_neghip_raw_read_as_float(tmp_path):
    line = error_leaves_nothing(tmp_path, "render", need(NEGHIP_RAW), "--dims", "64", "-o",
                                tmp_path / "i.png")
    assert "size 262144 bytes" in line and "fits uint8 64x64x64: use --type uint8" in line, line


# ---- 4. --threads after the command ------------------------------------------------------------


@pytest.mark.parametrize("where", ["before", "after"])
def test_threads_before_or_after_the_command(small, where):
    t = small["dir"]
    cmd = ["render", small["model"], "--tf", small["tf"], "--size", "8", "-o", t / "i.png"]
    args = ["--threads", "1", *cmd] if where == "before" else [*cmd, "--threads", "1"]
    run_ok(*args)
    assert (t / "i.png").is_file()


def test_threads_after_every_command_is_accepted(small):
    t = small["dir"]
    run_ok("generate", "tangle", "--dims", "4", "-o", t / "g.vti", "--threads", "2")
    r = run_ok("build", small["ensemble"], "--gmm", "2", "-o", t / "b.vti", "--threads", "1")
    assert "1 threads" in r.stderr
    run_ok("probe", small["model"], "--point", "1,1,1", "--model", "mean", "--tf", small["tf"],
           "--threads", "1")


@pytest.mark.parametrize("value", ["-1", "abc", "5000"])
def test_threads_after_the_command_is_checked(small, value):
    t = small["dir"]
    line = error_leaves_nothing(t, "render", small["model"], "--tf", small["tf"], "--size", "8",
                                "-o", t / "i.png", "--threads", value)
    assert "--threads" in line and value in line


# ---- 5. a truncated NetCDF-4 file says so ------------------------------------------------------


def _hdf5_header(eof):
    """An HDF5 superblock v2 (what netCDF-4 writes) claiming `eof` bytes, and nothing more."""
    sb = b"\x89HDF\r\n\x1a\n" + bytes([2, 8, 8, 0])
    sb += struct.pack("<QQQQ", 0, 0xFFFFFFFFFFFFFFFF, eof, 48)
    return sb + b"\0" * 4  # checksum (not checked by us)


def test_cut_hdf5_file_is_named_truncated(tmp_path):
    nc = tmp_path / "ens.nc"
    nc.write_bytes(_hdf5_header(100000) + b"\0" * 200)
    line = error_leaves_nothing(tmp_path, "build", nc, "-o", tmp_path / "m.vti")
    assert "ens.nc" in line and "truncated NetCDF-4/HDF5 file" in line, line
    assert "expected 100000 bytes, found 248" in line, line
    cut = tmp_path / "head.nc"
    cut.write_bytes(_hdf5_header(100000)[:20])
    line = error_leaves_nothing(tmp_path, "render", cut, "-o", tmp_path / "i.png")
    assert "head.nc" in line and "truncated or damaged" in line, line


def test_truncated_fuel_netcdf4(tmp_path):
    data = need(FUEL_NC).read_bytes()
    for keep, words in [(0.4, "truncated NetCDF-4/HDF5 file"), (0.999, "truncated")]:
        cut = tmp_path / "ens.nc"
        cut.write_bytes(data[: int(len(data) * keep)])
        line = error_leaves_nothing(tmp_path, "build", cut, "-o", tmp_path / "m.vti")
        assert "ens.nc" in line and words in line and "HDF error" not in line.split("(")[0], line
        cut.unlink()


def test_damaged_fuel_netcdf4(tmp_path):
    data = bytearray(need(FUEL_NC).read_bytes())
    data[200:4000] = b"\x5a" * 3800  # the object headers after the superblock
    bad = tmp_path / "ens.nc"
    bad.write_bytes(bytes(data))
    line = error_leaves_nothing(tmp_path, "build", bad, "-o", tmp_path / "m.vti")
    assert "ens.nc" in line and "truncated or damaged" in line, line


# ---- 6. one message per failure -------------------------------------------------------------


def test_vti_that_fails_both_readers_alike_is_reported_once(small):
    t = small["dir"]
    data = small["model"].read_bytes()
    cut = t / "cut.vti"
    cut.write_bytes(data[: data.index(b"<PointData") + 5])  # inside the XML header
    for args in (["render", cut, "--tf", small["tf"], "--size", "8", "-o", t / "i.png"],
                 ["probe", cut, "--point", "1,1,1", "--model", "mean", "--tf", small["tf"]]):
        line = error_leaves_nothing(t, *args)
        assert line.count("cut.vti") == 1, line
        assert "neither a model" not in line, line
    missing = t / "absent.vti"
    line = error_leaves_nothing(t, "render", missing, "--tf", small["tf"], "-o", t / "i.png")
    assert line.count("absent.vti") == 1 and "no such file" in line, line


def test_vti_that_is_neither_model_nor_field_names_both_reasons(small):
    # No point arrays: the two readers fail for different reasons, and both are named.
    t = small["dir"]
    vti = t / "empty.vti"
    vti.write_text(
        '<?xml version="1.0"?>\n<VTKFile type="ImageData" version="1.0" '
        'byte_order="LittleEndian">\n<ImageData WholeExtent="0 1 0 1 0 1" Origin="0 0 0" '
        'Spacing="1 1 1">\n<Piece Extent="0 1 0 1 0 1">\n<PointData>\n</PointData>\n'
        '</Piece>\n</ImageData>\n</VTKFile>\n')
    line = error_leaves_nothing(t, "render", vti, "--tf", small["tf"], "--size", "8", "-o",
                                t / "i.png")
    assert "neither a model" in line and "no model arrays" in line and "point data" in line, line


# ---- 7. an ensemble NetCDF where a field is expected ------------------------------------------


def test_downsampling_an_ensemble_netcdf_says_it_is_an_ensemble(small):
    t = small["dir"]
    line = error_leaves_nothing(t, "build", small["ensemble"], "--downsample", "2", "-o",
                                t / "x.vti")
    for m in ["e.nc holds a 3-member ensemble", "variable 'tangle'", "member,z,y,x",
              "--downsample reduces one field", "drop --downsample"]:
        assert m in line, line


def test_rendering_an_ensemble_netcdf_names_udvr_build(small):
    t = small["dir"]
    line = error_leaves_nothing(t, "render", small["ensemble"], "--size", "8", "-o", t / "i.png")
    assert "3-member ensemble" in line and "not one field" in line and "udvr build" in line, line
    line = error_leaves_nothing(t, "perturb", small["ensemble"], "--var", "tangle", "-o",
                                t / "p.nc")
    assert "3-member ensemble" in line, line


def test_fuel_ensemble_downsample(tmp_path):
    line = error_leaves_nothing(tmp_path, "build", need(FUEL_NC), "--downsample", "4", "-o",
                                tmp_path / "m.vti")
    assert "holds a 10-member ensemble (variable 'fuel', dims member,z,y,x)" in line, line
    assert "drop --downsample" in line


# ---- 8. a plain field where a model is needed -------------------------------------------------


@pytest.mark.parametrize("model,array", [("quantile-mean", "quantiles"),
                                         ("quantile-range", "quantiles"),
                                         ("iqr", "iqr"), ("gmm-ordered", "gmm")])
@pytest.mark.parametrize("cmd", ["render", "probe"])
def test_plain_field_with_a_distribution_model_names_udvr_build(small, cmd, model, array):
    t = small["dir"]
    if cmd == "render":
        args = ["render", small["field"], "--model", model, "--tf", small["tf"], "--size", "8",
                "-o", t / "x.png"]
    else:
        args = ["probe", small["field"], "--point", "1,1,1", "--model", model, "--tf",
                small["tf"]]
    line = error_leaves_nothing(t, *args)
    for m in ["plain field", f"'{array}'", "udvr build", "--downsample", model]:
        assert m in line, line
    assert "--quantiles" not in line, line


@pytest.mark.parametrize("model", ["mean", "gaussian", "uniform"])
def test_plain_field_with_a_mean_based_model_renders(small, model):
    t = small["dir"]
    run_ok("render", small["field"], "--model", model, "--tf", small["tf"], "--size", "8", "-o",
           t / "x.png")


def test_model_without_quantiles_still_says_rebuild(small):
    t = small["dir"]
    noq = t / "noq.vti"
    run_ok("build", small["ensemble"], "--quantiles", "0", "--gmm", "0", "-o", noq)
    line = error_leaves_nothing(t, "render", noq, "--model", "quantile-mean", "--tf", small["tf"],
                                "--size", "8", "-o", t / "x.png")
    assert "quantiles" in line and "plain field" not in line, line


# ---- 9. one prefix style ------------------------------------------------------------------------


def test_tf_reader_warning_has_the_udvr_prefix(small):
    t = small["dir"]
    tf = write_tf(t / "mid.json", points=[-10, 0, 0.3, 0, 30, 1, 0.5, 0])
    r = run_ok("render", small["model"], "--tf", tf, "--size", "8", "-o", t / "i.png")
    warnings = [ln for ln in r.stderr.splitlines() if "midpoint" in ln]
    assert len(warnings) == 1 and warnings[0].startswith("udvr: warning: "), r.stderr
    noalpha = t / "noalpha.json"
    noalpha.write_text('[{"Name": "x", "RGBPoints": [-10, 0, 0, 1, 30, 1, 0, 0], '
                       '"ColorSpace": "Lab"}]')
    r = run_ok("render", small["model"], "--tf", noalpha, "--size", "8", "-o", t / "i.png")
    notes = [ln for ln in r.stderr.splitlines() if "Points" in ln or "ColorSpace" in ln]
    assert len(notes) == 2 and all(ln.startswith("udvr: note: ") for ln in notes), r.stderr


def test_every_stderr_line_has_a_known_prefix(small):
    """Warnings, notes and errors carry `udvr: `; progress and info lines name their command."""
    t = small["dir"]
    runs = [
        run_udvr("build", *members(t, 3), "--gmm", "6", "-o", t / "m3.vti"),
        run_udvr("render", small["field"], "--model", "iqr", "--tf", small["tf"], "-o",
                 t / "x.png"),
        run_udvr("perturb", small["field"], "--members", "3", "-o", t / "p.vti"),
    ]
    for r in runs:
        for ln in r.stderr.splitlines():
            assert ln.startswith(("udvr: error: ", "udvr: warning: ", "udvr: note: ", "build: ",
                                  "render: ", "perturb: ")), ln
