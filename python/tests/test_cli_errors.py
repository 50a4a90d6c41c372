"""End-to-end tests of the `udvr` binary: bad input and the output guarantees (SPEC §8).

Every bad input (missing file, wrong dimensions, truncated data, NaN, nonsense flags) gets one
line "udvr: error: …" on stderr naming the offending thing, a non-zero exit, and leaves no output
file (nor a temporary one) behind. The good pipeline writes every file it is asked for.
Grids are tiny (16³ and smaller) so the whole file runs in seconds.
"""
import ast
import json
import math
import pathlib
import struct

import pytest

from conftest import (
    assert_one_line_error,
    listing,
    run_ok,
    run_udvr,
    truncated_copy,
    write_nrrd,
    write_tf,
)

pytestmark = pytest.mark.usefixtures("udvr_binary")


def read_npy(path):
    """A tiny .npy reader (float32, C order) so the test needs no NumPy: (shape, values)."""
    data = pathlib.Path(path).read_bytes()
    assert data[:6] == b"\x93NUMPY", "not a .npy file"
    major = data[6]
    if major == 1:
        (hlen,) = struct.unpack("<H", data[8:10])
        start = 10
    else:
        (hlen,) = struct.unpack("<I", data[8:12])
        start = 12
    header = ast.literal_eval(data[start : start + hlen].decode("latin1"))
    assert header["descr"] in ("<f4", "=f4"), header
    assert not header["fortran_order"]
    shape = tuple(header["shape"])
    n = math.prod(shape)
    body = data[start + hlen :]
    assert len(body) == 4 * n, (len(body), shape)
    return shape, struct.unpack(f"<{n}f", body)


def write_npy(path, shape, values):
    """A float32 .npy (version 1.0)."""
    header = "{'descr': '<f4', 'fortran_order': False, 'shape': %s, }" % (tuple(shape),)
    pad = 64 - (10 + len(header) + 1) % 64
    header = header + " " * pad + "\n"
    body = struct.pack(f"<{len(values)}f", *values)
    pathlib.Path(path).write_bytes(
        b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header.encode() + body
    )
    return pathlib.Path(path)


# ---- the good pipeline -------------------------------------------------------------------------


def test_good_pipeline_writes_every_file(tmp_path):
    f, e, m = tmp_path / "f.vti", tmp_path / "e.nc", tmp_path / "m.vti"
    png, npy = tmp_path / "img.png", tmp_path / "img.npy"
    tf = write_tf(tmp_path / "tf.json", [-10, 0, 0, 1, 30, 1, 1, 0], [-10, 0, 0.5, 0, 30, 1, 0.5, 0])
    run_ok("generate", "tangle", "--dims", "16", "-o", f)
    assert f.stat().st_size > 0  # compressed
    run_ok("perturb", f, "--members", "5", "-o", e)
    assert e.stat().st_size > 5 * 16**3 * 4  # NetCDF, float32
    run_ok("build", e, "-o", m)
    assert m.stat().st_size > 0

    r = run_ok("probe", m, "--point", "8,8,8", "--model", "quantile-range", "--tf", tf, "--json")
    j = json.loads(r.stdout)
    assert j["model"] == "quantile-range"
    assert list(j["point"]) == [8, 8, 8]
    assert len(j["expected_rgba"]) == 4
    assert all(0.0 <= v <= 1.0 for v in j["expected_rgba"])
    assert len(j["boundaries"]) == 9
    assert j["boundaries"] == sorted(j["boundaries"])

    run_ok("render", m, "--model", "quantile-range", "--tf", tf, "--size", "32x32",
           "--float", npy, "-o", png)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    shape, values = read_npy(npy)
    assert shape == (32, 32, 4)
    assert all(math.isfinite(v) and 0.0 <= v <= 1.0 for v in values)
    assert min(values) < max(values)  # something was drawn

    r = run_ok("compare", png, png)
    assert float(r.stdout) == 0.0
    diff = tmp_path / "diff.png"
    r = run_ok("compare", npy, npy, "--diff", diff)
    assert float(r.stdout) == 0.0 and diff.is_file()
    # Nothing but the requested files: no temporaries left beside them.
    assert listing(tmp_path) == sorted(
        ["f.vti", "e.nc", "m.vti", "img.png", "img.npy", "tf.json", "diff.png"]
    )


def test_missing_netcdf_coordinates_are_noted_once_on_success(tmp_path):
    field = _netcdf(tmp_path / "f.nc", (4, 4, 4), [float(i) for i in range(64)])
    r = run_ok("perturb", field, "--members", "3", "-o", tmp_path / "e.nc")
    notes = [ln for ln in r.stderr.splitlines() if ln.startswith("udvr: note:")]
    assert len(notes) == 1 and "f.nc" in notes[0] and "coordinate" in notes[0], r.stderr


def test_errors_say_nothing_on_stdout_and_leave_no_output(pipeline, tmp_path):
    r = run_udvr("compare", pipeline.png, tmp_path / "absent.png")
    assert_one_line_error(r, "absent.png")
    assert r.stdout == ""


# ---- bad input: one case per row ---------------------------------------------------------------
# Each case builds (args, mentions) from the shared good files `p` and a scratch folder `t`; the
# command writes into `t/out`, which must stay empty, and `t` must hold nothing new afterwards.

OUT = "out"


def o(t, name):
    return t / OUT / name


def _nan_nrrd(t):
    vals = [float(i) for i in range(64)]
    vals[21] = float("nan")
    return write_nrrd(t / "nan.nrrd", vals, (4, 4, 4))


def _raw(t, n=64):
    path = t / "vol.raw"
    path.write_bytes(struct.pack(f"<{n}f", *[float(i) for i in range(n)]))
    return path


def _netcdf(path, dims, values, member=None):
    """A NetCDF-3 file without coordinate variables (scipy), variable 'val' on z,y,x."""
    netcdf = pytest.importorskip("scipy.io").netcdf_file
    np = pytest.importorskip("numpy")
    f = netcdf(str(path), "w")
    names = ("z", "y", "x") if member is None else ("member", "z", "y", "x")
    shape = tuple(reversed(dims)) if member is None else (member, *reversed(dims))
    for name, n in zip(names, shape):
        f.createDimension(name, n)
    f.createVariable("val", "f4", names)[:] = np.asarray(values, dtype="f4").reshape(shape)
    f.close()
    return path


def _nc_nan(t):
    vals = [float(i) for i in range(64)]
    vals[21] = float("nan")
    return _netcdf(t / "nan.nc", (4, 4, 4), vals)


def _raw_nan(t):
    path = _raw(t)
    data = bytearray(path.read_bytes())
    data[40:44] = struct.pack("<f", float("nan"))
    path.write_bytes(bytes(data))
    return path


def _tf_not_json(t):
    return write_tf(t / "bad.json", raw="RGBPoints: 0 0 0 1\n")


def _tf_unsorted(t):
    return write_tf(t / "bad.json", points=[0, 0, 0.5, 0, 20, 0.5, 0.5, 0, 10, 1, 0.5, 0])


def _tf_alpha(t):
    return write_tf(t / "bad.json", points=[0, 0, 0.5, 0, 20, 1.5, 0.5, 0])


def _tf_empty(t):
    return write_tf(t / "bad.json", raw="[]")


def _one_member_nc(p, t):
    return p.field_nc


BAD_TFS = {
    "tf-not-json": (_tf_not_json, ["bad.json"]),
    "tf-unsorted": (_tf_unsorted, ["bad.json"]),
    "tf-alpha>1": (_tf_alpha, ["bad.json"]),
    "tf-empty": (_tf_empty, ["bad.json"]),
}

CASES = {
    # ---- generate
    "generate/unknown-field": lambda p, t: (
        ["generate", "torus", "--dims", "8", "-o", o(t, "f.vti")], ["torus"]),
    "generate/dims-0": lambda p, t: (
        ["generate", "tangle", "--dims", "0", "-o", o(t, "f.vti")], ["--dims"]),
    "generate/dims-2-components": lambda p, t: (
        ["generate", "tangle", "--dims", "4,4", "-o", o(t, "f.vti")], ["--dims", "4,4"]),
    "generate/dims-abc": lambda p, t: (
        ["generate", "tangle", "--dims", "abc", "-o", o(t, "f.vti")], ["--dims", "abc"]),
    "generate/unknown-flag": lambda p, t: (
        ["generate", "tangle", "--dims", "8", "--colour", "red", "-o", o(t, "f.vti")],
        ["--colour"]),
    "generate/missing-output-dir": lambda p, t: (
        ["generate", "tangle", "--dims", "8", "-o", t / "nodir" / "f.vti"], ["nodir"]),
    "generate/unknown-extension": lambda p, t: (
        ["generate", "tangle", "--dims", "8", "-o", o(t, "f.xyz")], ["f.xyz"]),
    "generate/no-subcommand-args": lambda p, t: (["generate"], ["field"]),
    "generate/output-is-a-directory": lambda p, t: (
        ["generate", "tangle", "--dims", "4", "-o", t / OUT], [OUT]),
    # ---- the command itself and global flags
    "udvr/no-command": lambda p, t: ([], ["subcommand"]),
    "udvr/unknown-command": lambda p, t: (["frobnicate", "-o", o(t, "x")], ["frobnicate"]),
    "udvr/unknown-global-flag": lambda p, t: (
        ["--bogus", "generate", "tangle", "--dims", "4", "-o", o(t, "f.vti")], ["--bogus"]),
    "udvr/threads-negative": lambda p, t: (
        ["--threads", "-1", "generate", "tangle", "--dims", "4", "-o", o(t, "f.vti")],
        ["--threads", "-1"]),
    "udvr/threads-abc": lambda p, t: (
        ["--threads", "abc", "generate", "tangle", "--dims", "4", "-o", o(t, "f.vti")],
        ["--threads", "abc"]),
    # ---- perturb
    "perturb/missing-input": lambda p, t: (
        ["perturb", t / "absent.vti", "--members", "3", "-o", o(t, "e.nc")], ["absent.vti"]),
    "perturb/directory-input": lambda p, t: (
        ["perturb", p.dir, "--members", "3", "-o", o(t, "e.nc")], [p.dir.name]),
    "perturb/truncated-vti": lambda p, t: (
        ["perturb", truncated_copy(p.field, t / "cut.vti"), "--members", "3", "-o",
         o(t, "e.nc")], ["cut.vti"]),
    "perturb/truncated-nc": lambda p, t: (
        ["perturb", truncated_copy(p.field_nc, t / "cut.nc"), "--members", "3", "-o",
         o(t, "e.nc")], ["cut.nc"]),
    "perturb/truncated-nrrd": lambda p, t: (
        ["perturb", truncated_copy(p.nrrd, t / "cut.nrrd", 0.8), "--members", "3", "-o",
         o(t, "e.nc")], ["cut.nrrd"]),
    "perturb/nrrd-nan": lambda p, t: (
        ["perturb", _nan_nrrd(t), "--members", "3", "-o", o(t, "e.nc")], ["nan.nrrd"]),
    "perturb/netcdf-nan-no-coordinates": lambda p, t: (
        ["perturb", _nc_nan(t), "--members", "3", "-o", o(t, "e.nc")], ["nan.nc", "nan"]),
    "perturb/nrrd-wrong-sizes": lambda p, t: (
        ["perturb", write_nrrd(t / "bad.nrrd", [0.0] * 64, (4, 4, 4), sizes="4 4"),
         "--members", "3", "-o", o(t, "e.nc")], ["bad.nrrd", "sizes"]),
    "perturb/nrrd-too-few-values": lambda p, t: (
        ["perturb", write_nrrd(t / "bad.nrrd", [0.0] * 60, (4, 4, 4)),
         "--members", "3", "-o", o(t, "e.nc")], ["bad.nrrd"]),
    "perturb/nrrd-bad-type": lambda p, t: (
        ["perturb", write_nrrd(t / "bad.nrrd", [0.0] * 64, (4, 4, 4), type_name="complex"),
         "--members", "3", "-o", o(t, "e.nc")], ["bad.nrrd", "complex"]),
    "perturb/not-nrrd": lambda p, t: (
        ["perturb", write_tf(t / "bad.nrrd", raw="hello\n"), "--members", "3", "-o",
         o(t, "e.nc")], ["bad.nrrd"]),
    "perturb/raw-without-dims": lambda p, t: (
        ["perturb", _raw(t), "--members", "3", "-o", o(t, "e.nc")], ["vol.raw"]),
    "perturb/members-1": lambda p, t: (
        ["perturb", p.field, "--members", "1", "-o", o(t, "e.nc")], ["members"]),
    "perturb/members-0": lambda p, t: (
        ["perturb", p.field, "--members", "0", "-o", o(t, "e.nc")], ["members"]),
    "perturb/members-abc": lambda p, t: (
        ["perturb", p.field, "--members", "abc", "-o", o(t, "e.nc")], ["--members", "abc"]),
    "perturb/unknown-noise": lambda p, t: (
        ["perturb", p.field, "--members", "3", "--noise", "pink", "-o", o(t, "e.nc")],
        ["pink"]),
    "perturb/negative-sigma": lambda p, t: (
        ["perturb", p.field, "--members", "3", "--noise", "gaussian", "--sigma", "-1", "-o",
         o(t, "e.nc")], ["sigma"]),
    "perturb/infinite-sigma": lambda p, t: (
        ["perturb", p.field, "--members", "3", "--sigma", "inf", "-o", o(t, "e.nc")],
        ["--sigma"]),
    "perturb/outlier-fraction-2": lambda p, t: (
        ["perturb", p.field, "--members", "3", "--outlier-fraction", "2", "-o", o(t, "e.nc")],
        ["--outlier-fraction"]),
    "perturb/seed-negative": lambda p, t: (
        ["perturb", p.field, "--members", "3", "--seed", "-1", "-o", o(t, "e.nc")],
        ["--seed", "-1"]),
    "perturb/unknown-var": lambda p, t: (
        ["perturb", p.field, "--members", "3", "--var", "nosuch", "-o", o(t, "e.nc")],
        ["nosuch"]),
    "perturb/unknown-flag": lambda p, t: (
        ["perturb", p.field, "--membres", "3", "-o", o(t, "e.nc")], ["--membres"]),
    "perturb/missing-output-dir": lambda p, t: (
        ["perturb", p.field, "--members", "3", "-o", t / "nodir" / "e.nc"], ["nodir"]),
    # ---- build
    "build/missing-input": lambda p, t: (
        ["build", t / "absent.nc", "-o", o(t, "m.vti")], ["absent.nc"]),
    "build/directory-input": lambda p, t: (
        ["build", p.dir, "-o", o(t, "m.vti")], [p.dir.name]),
    "build/glob-matches-nothing": lambda p, t: (
        ["build", str(t / "nothing_*.vti"), "-o", o(t, "m.vti")], ["nothing_*.vti"]),
    "build/truncated-nc": lambda p, t: (
        ["build", truncated_copy(p.ensemble, t / "cut.nc"), "-o", o(t, "m.vti")], ["cut.nc"]),
    "build/truncated-vti-member": lambda p, t: (
        ["build", p.field, truncated_copy(p.field, t / "cut.vti"), "-o", o(t, "m.vti")],
        ["cut.vti"]),
    "build/one-member-file": lambda p, t: (
        ["build", p.field, "-o", o(t, "m.vti")], ["member"]),
    "build/one-member-netcdf": lambda p, t: (
        ["build", p.field_nc, "-o", o(t, "m.vti")], ["member"]),
    "build/one-member-netcdf-ensemble": lambda p, t: (
        ["build", _netcdf(t / "one.nc", (4, 4, 4), [0.0] * 64, member=1), "-o", o(t, "m.vti")],
        ["one.nc", "1 member"]),
    "build/netcdf-members-nan-no-coordinates": lambda p, t: (
        ["build", _netcdf(t / "ens.nc", (4, 4, 4), [0.0] * 127 + [float("nan")], member=2),
         "-o", o(t, "m.vti")], ["ens.nc", "member 1"]),
    "build/members-differ-in-dims": lambda p, t: (
        ["build", write_nrrd(t / "a.nrrd", [0.0] * 64, (4, 4, 4)),
         write_nrrd(t / "b.nrrd", [0.0] * 60, (4, 5, 3)), "-o", o(t, "m.vti")], ["b.nrrd"]),
    "build/nan-member": lambda p, t: (
        ["build", write_nrrd(t / "a.nrrd", [0.0] * 64, (4, 4, 4)), _nan_nrrd(t),
         "-o", o(t, "m.vti")], ["nan.nrrd"]),
    "build/quantiles-negative": lambda p, t: (
        ["build", p.ensemble, "--quantiles", "-1", "-o", o(t, "m.vti")], ["quantiles"]),
    # --gmm larger than the samples per voxel is lowered with a warning: test_cli_first_use.py
    "build/gmm-negative": lambda p, t: (
        ["build", p.ensemble, "--gmm", "-2", "-o", o(t, "m.vti")], ["gmm"]),
    "build/downsample-1": lambda p, t: (
        ["build", p.field, "--downsample", "1", "-o", o(t, "m.vti")], ["downsample"]),
    "build/downsample-0": lambda p, t: (
        ["build", p.field, "--downsample", "0", "-o", o(t, "m.vti")], ["downsample"]),
    "build/downsample-larger-than-grid": lambda p, t: (
        ["build", p.field, "--downsample", "17", "-o", o(t, "m.vti")], ["downsample"]),
    "build/downsample-nan": lambda p, t: (
        ["build", _nan_nrrd(t), "--downsample", "2", "-o", o(t, "m.vti")], ["nan.nrrd"]),
    "build/downsample-two-inputs": lambda p, t: (
        ["build", p.field, p.field, "--downsample", "2", "-o", o(t, "m.vti")], ["downsample"]),
    "build/downsample-an-ensemble": lambda p, t: (
        ["build", p.ensemble, "--downsample", "2", "-o", o(t, "m.vti")], ["ensemble.nc"]),
    "build/member-given-twice": lambda p, t: (
        ["build", p.field, p.field, "-o", o(t, "m.vti")], ["field.vti"]),
    "build/unknown-density": lambda p, t: (
        ["build", p.ensemble, "--density", "histo", "-o", o(t, "m.vti")], ["histo"]),
    "build/bad-bandwidth": lambda p, t: (
        ["build", p.ensemble, "--density", "kde", "--bandwidth", "wide", "-o", o(t, "m.vti")],
        ["wide"]),
    "build/negative-bandwidth": lambda p, t: (
        ["build", p.ensemble, "--density", "kde", "--bandwidth", "-1", "-o", o(t, "m.vti")],
        ["bandwidth"]),
    "build/tail-eps-out-of-range": lambda p, t: (
        ["build", p.ensemble, "--density", "kde", "--tail-eps", "0.7", "-o", o(t, "m.vti")],
        ["tail-eps"]),
    "build/unknown-var": lambda p, t: (
        ["build", p.ensemble, "--var", "nosuch", "-o", o(t, "m.vti")], ["nosuch"]),
    "build/unknown-flag": lambda p, t: (
        ["build", p.ensemble, "--quantile", "4", "-o", o(t, "m.vti")], ["--quantile"]),
    "build/missing-output-dir": lambda p, t: (
        ["build", p.ensemble, "-o", t / "nodir" / "m.vti"], ["nodir"]),
    # ---- probe
    "probe/missing-model": lambda p, t: (
        ["probe", t / "absent.vti", "--point", "1,1,1", "--model", "mean", "--tf", p.tf],
        ["absent.vti"]),
    "probe/directory-model": lambda p, t: (
        ["probe", p.dir, "--point", "1,1,1", "--model", "mean", "--tf", p.tf], [p.dir.name]),
    "probe/truncated-model": lambda p, t: (
        ["probe", truncated_copy(p.model, t / "cut.vti"), "--point", "1,1,1", "--model",
         "mean", "--tf", p.tf], ["cut.vti"]),
    "probe/field-not-model": lambda p, t: (
        ["probe", p.field, "--point", "1,1,1", "--model", "quantile-mean", "--tf", p.tf],
        ["quantiles"]),
    "probe/unknown-model": lambda p, t: (
        ["probe", p.model, "--point", "1,1,1", "--model", "gauss", "--tf", p.tf], ["gauss"]),
    "probe/model-without-quantiles": lambda p, t: (
        ["probe", p.model_noq, "--point", "1,1,1", "--model", "quantile-range", "--tf", p.tf],
        ["quantile"]),
    "probe/point-outside": lambda p, t: (
        ["probe", p.model, "--point", "99,1,1", "--model", "mean", "--tf", p.tf], ["99"]),
    "probe/point-negative": lambda p, t: (
        ["probe", p.model, "--point", "-1,1,1", "--model", "mean", "--tf", p.tf], ["point"]),
    "probe/point-2-components": lambda p, t: (
        ["probe", p.model, "--point", "1,2", "--model", "mean", "--tf", p.tf], ["--point"]),
    "probe/point-nan": lambda p, t: (
        ["probe", p.model, "--point", "nan,1,1", "--model", "mean", "--tf", p.tf], ["--point"]),
    "probe/missing-tf": lambda p, t: (
        ["probe", p.model, "--point", "1,1,1", "--model", "mean", "--tf", t / "absent.json"],
        ["absent.json"]),
    "probe/unknown-flag": lambda p, t: (
        ["probe", p.model, "--point", "1,1,1", "--model", "mean", "--tf", p.tf, "--xml"],
        ["--xml"]),
    "probe/plot-not-png": lambda p, t: (
        ["probe", p.model, "--point", "1,1,1", "--model", "mean", "--tf", p.tf, "--plot",
         o(t, "p.svg")], ["p.svg"]),
    "probe/quartile-needs-q-divisible-by-4": lambda p, t: (
        ["probe", p.model_q6, "--point", "1,1,1", "--model", "quartile-lower", "--tf", p.tf],
        ["quartile-lower", "4"]),
    "probe/unknown-uniform-width": lambda p, t: (
        ["probe", p.model, "--point", "1,1,1", "--model", "uniform", "--tf", p.tf,
         "--uniform-width", "wide"], ["wide"]),
    "probe/plot-missing-dir": lambda p, t: (
        ["probe", p.model, "--point", "1,1,1", "--model", "mean", "--tf", p.tf, "--plot",
         t / "nodir" / "p.png"], ["nodir"]),
    # ---- render
    "render/missing-input": lambda p, t: (
        ["render", t / "absent.vti", "--tf", p.tf, "--size", "8", "-o", o(t, "i.png")],
        ["absent.vti"]),
    "render/tf2-widgets-given-as-tf": lambda p, t: (
        ["render", p.model, "--tf", pathlib.Path(__file__).resolve().parents[2] / "data" / "tf2"
         / "tangle.json", "--size", "8", "-o", o(t, "i.png")], ["--tf2"]),
    "render/directory-input": lambda p, t: (
        ["render", p.dir, "--tf", p.tf, "--size", "8", "-o", o(t, "i.png")], [p.dir.name]),
    "render/truncated-vti": lambda p, t: (
        ["render", truncated_copy(p.model, t / "cut.vti"), "--tf", p.tf, "--size", "8", "-o",
         o(t, "i.png")], ["cut.vti"]),
    "render/truncated-nc": lambda p, t: (
        ["render", truncated_copy(p.field_nc, t / "cut.nc"), "--tf", p.tf, "--size", "8", "-o",
         o(t, "i.png")], ["cut.nc"]),
    "render/truncated-nrrd": lambda p, t: (
        ["render", truncated_copy(p.nrrd, t / "cut.nrrd", 0.8), "--tf", p.tf, "--size", "8",
         "-o", o(t, "i.png")], ["cut.nrrd"]),
    "render/nrrd-nan": lambda p, t: (
        ["render", _nan_nrrd(t), "--tf", p.tf, "--size", "8", "-o", o(t, "i.png")],
        ["nan.nrrd"]),
    "render/nrrd-missing-type": lambda p, t: (
        ["render", write_tf(t / "bad.nrrd", raw="NRRD0004\ndimension: 3\nsizes: 2 2 2\n"
                            "encoding: raw\n\n" + "\0" * 8),
         "--tf", p.tf, "--size", "8", "-o", o(t, "i.png")], ["bad.nrrd", "type"]),
    "render/raw-size-mismatch": lambda p, t: (
        ["render", _raw(t), "--dims", "5", "--tf", p.tf, "--size", "8", "-o", o(t, "i.png")],
        ["vol.raw"]),
    "render/raw-without-dims": lambda p, t: (
        ["render", _raw(t), "--tf", p.tf, "--size", "8", "-o", o(t, "i.png")], ["vol.raw"]),
    "render/raw-unknown-type": lambda p, t: (
        ["render", _raw(t), "--dims", "4", "--type", "float16", "--tf", p.tf, "--size", "8",
         "-o", o(t, "i.png")], ["float16"]),
    "render/unknown-model": lambda p, t: (
        ["render", p.model, "--model", "median", "--tf", p.tf, "--size", "8", "-o",
         o(t, "i.png")], ["median"]),
    "render/model-without-quantiles": lambda p, t: (
        ["render", p.model_noq, "--model", "quantile-range", "--tf", p.tf, "--size", "8", "-o",
         o(t, "i.png")], ["quantile"]),
    "render/raw-nan": lambda p, t: (
        ["render", _raw_nan(t), "--dims", "4", "--tf", p.tf, "--size", "8", "-o",
         o(t, "i.png")], ["vol.raw"]),
    "render/raw-dims-2-components": lambda p, t: (
        ["render", _raw(t), "--dims", "4,16", "--tf", p.tf, "--size", "8", "-o",
         o(t, "i.png")], ["--dims"]),
    "render/background-out-of-range": lambda p, t: (
        ["render", p.model, "--tf", p.tf, "--size", "8", "--background", "2,0,0", "-o",
         o(t, "i.png")], ["--background"]),
    "render/frames-negative": lambda p, t: (
        ["render", p.model, "--tf", p.tf, "--size", "8", "--frames", "-1", "-o",
         o(t, "i.png")], ["--frames"]),
    "render/zoom-0": lambda p, t: (
        ["render", p.model, "--tf", p.tf, "--size", "8", "--zoom", "0", "-o", o(t, "i.png")],
        ["--zoom"]),
    "render/size-0x5": lambda p, t: (
        ["render", p.model, "--tf", p.tf, "--size", "0x5", "-o", o(t, "i.png")], ["--size"]),
    "render/size-abc": lambda p, t: (
        ["render", p.model, "--tf", p.tf, "--size", "8by8", "-o", o(t, "i.png")], ["--size"]),
    "render/step-negative": lambda p, t: (
        ["render", p.model, "--tf", p.tf, "--size", "8", "--step", "-1", "-o", o(t, "i.png")],
        ["--step"]),
    "render/unit-distance-negative": lambda p, t: (
        ["render", p.model, "--tf", p.tf, "--size", "8", "--unit-distance", "-1", "-o",
         o(t, "i.png")], ["--unit-distance"]),
    "render/view-angle-0": lambda p, t: (
        ["render", p.model, "--tf", p.tf, "--size", "8", "--view-angle", "0", "-o",
         o(t, "i.png")], ["--view-angle"]),
    "render/early-exit-2": lambda p, t: (
        ["render", p.model, "--tf", p.tf, "--size", "8", "--early-exit", "2", "-o",
         o(t, "i.png")], ["--early-exit"]),
    "render/realizations-0": lambda p, t: (
        ["render", p.model, "--model", "gmm-mc", "--tf", p.tf, "--size", "8",
         "--realizations", "0", "-o", o(t, "i.png")], ["--realizations"]),
    "render/position-2-components": lambda p, t: (
        ["render", p.model, "--tf", p.tf, "--size", "8", "--position", "1,2", "-o",
         o(t, "i.png")], ["--position"]),
    "render/missing-tf": lambda p, t: (
        ["render", p.model, "--tf", t / "absent.json", "--size", "8", "-o", o(t, "i.png")],
        ["absent.json"]),
    "render/unknown-flag": lambda p, t: (
        ["render", p.model, "--tf", p.tf, "--size", "8", "--fov", "30", "-o", o(t, "i.png")],
        ["--fov"]),
    "render/output-not-png": lambda p, t: (
        ["render", p.model, "--tf", p.tf, "--size", "8", "-o", o(t, "i.jpg")], ["i.jpg"]),
    "render/missing-output-dir": lambda p, t: (
        ["render", p.model, "--tf", p.tf, "--size", "8", "-o", t / "nodir" / "i.png"],
        ["nodir"]),
    "render/float-missing-dir": lambda p, t: (
        ["render", p.model, "--tf", p.tf, "--size", "8", "--float", t / "nodir" / "i.npy",
         "-o", o(t, "i.png")], ["nodir"]),
    "render/png-missing-dir-after-float": lambda p, t: (
        ["render", p.model, "--tf", p.tf, "--size", "8", "--float", o(t, "i.npy"),
         "-o", t / "nodir" / "i.png"], ["nodir"]),
    # ---- compare
    "compare/missing-file": lambda p, t: (
        ["compare", t / "absent.png", p.png], ["absent.png"]),
    "compare/directory": lambda p, t: (["compare", p.png, p.dir], [p.dir.name]),
    "compare/truncated-png": lambda p, t: (
        ["compare", truncated_copy(p.png, t / "cut.png"), p.png], ["cut.png"]),
    "compare/truncated-npy": lambda p, t: (
        ["compare", truncated_copy(p.npy, t / "cut.npy", 0.9), p.npy], ["cut.npy"]),
    "compare/npy-nan": lambda p, t: (
        ["compare", write_npy(t / "nan.npy", (2, 2, 4), [float("nan")] + [0.5] * 15),
         write_npy(t / "ok.npy", (2, 2, 4), [0.5] * 16)], ["nan.npy"]),
    "compare/size-mismatch": lambda p, t: (["compare", p.png, p.png_small], ["32"]),
    "compare/not-an-image": lambda p, t: (["compare", p.tf, p.png], ["tf.json"]),
    "compare/diff-missing-dir": lambda p, t: (
        ["compare", p.png, p.png, "--diff", t / "nodir" / "d.png"], ["nodir"]),
    "compare/unknown-flag": lambda p, t: (
        ["compare", p.png, p.png, "--metric", "psnr"], ["--metric"]),
    "compare/one-image": lambda p, t: (["compare", p.png], ["truth"]),
    # ---- experiment
    "experiment/unknown-name": lambda p, t: (
        ["experiment", "torus", "-o", o(t, "exp")], ["torus"]),
    "experiment/unknown-flag": lambda p, t: (
        ["experiment", "tangle", "--quik", "-o", o(t, "exp")], ["--quik"]),
    "experiment/missing-tf-dir": lambda p, t: (
        ["experiment", "tangle", "--quick", "--tf-dir", t / "notfs", "-o", o(t, "exp")],
        ["notfs"]),
    "experiment/missing-chest-data": lambda p, t: (
        ["experiment", "chest", "--quick", "--data-dir", t / "nodata", "-o", o(t, "exp")],
        ["nodata"]),
    "experiment/output-under-a-file": lambda p, t: (
        ["experiment", "tangle", "--quick", "-o", p.tf / "exp"], ["tf.json"]),
}

for _name, (_make, _mentions) in BAD_TFS.items():
    CASES[f"probe/{_name}"] = (
        lambda make, mentions: lambda p, t: (
            ["probe", p.model, "--point", "1,1,1", "--model", "mean", "--tf", make(t)], mentions)
    )(_make, _mentions)
    CASES[f"render/{_name}"] = (
        lambda make, mentions: lambda p, t: (
            ["render", p.model, "--tf", make(t), "--size", "8", "-o", o(t, "i.png")], mentions)
    )(_make, _mentions)

# Cases known to fail, name -> reason; strict xfails so a fix is noticed.
XFAIL = {}  # cases known to fail: name -> reason (none at present)


def _params():
    for name in sorted(CASES):
        marks = [pytest.mark.xfail(strict=True, reason=XFAIL[name])] if name in XFAIL else []
        yield pytest.param(name, id=name, marks=marks)


@pytest.mark.parametrize("case", list(_params()))
def test_bad_input_gives_one_line_error_and_no_output(case, pipeline, tmp_path):
    (tmp_path / OUT).mkdir()
    args, mentions = CASES[case](pipeline, tmp_path)
    before = listing(tmp_path)
    pipeline_before = listing(pipeline.dir)
    r = run_udvr(*args)
    assert_one_line_error(r, *mentions)
    assert listing(tmp_path / OUT) == [], "output left behind"
    assert listing(tmp_path) == before, "files appeared beside the inputs"
    assert listing(pipeline.dir) == pipeline_before, "files appeared beside the inputs"
