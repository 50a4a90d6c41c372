"""`udvr render ENSEMBLE --model members --float` and `udvr probe ENSEMBLE --model members --json`
against the NumPy reference (reference.RefMembers: every member classified by the mean-field
reference, the classifications averaged per sample, then composited along each ray as for any
model), from a NetCDF ensemble and from member files; and the error paths (a model file, a
single field, the memory cap), each one stderr line with a non-zero exit and no image left."""
import json

import numpy as np
import pytest

import model_table
import reference as ref
import refcase
from conftest import assert_one_line_error, listing, run_udvr

udvr = pytest.importorskip("udvr")
pytestmark = pytest.mark.usefixtures("udvr_binary")

TOL = 1e-4
W, H = 12, 9
# The models of the table (udvr.models()) that read an ensemble's members with a 1D TF.
KINDS = model_table.names("1d", members=True)


def random_ensemble(seed, tmp_path, n=7):
    """n members (float32, (n, Z, Y, X)) of one random field with noise of a different scale per
    member, written as ens.nc and as member files m_0.vti …; the reference and a random TF."""
    rng = np.random.default_rng(seed)
    shape = (6, 4, 5)
    base = rng.uniform(-1, 2, shape)
    scales = rng.uniform(0.05, 0.8, n)
    members = (base + scales[:, None, None, None] * rng.normal(size=(n,) + shape)).astype(
        np.float32)
    origin, spacing = rng.uniform(-3, 3, 3), rng.uniform(0.6, 1.6, 3)
    udvr.write_ensemble(str(tmp_path / "ens.nc"),
                        udvr.Ensemble(members, list(origin), list(spacing), "f"))
    for i, m in enumerate(members):
        udvr.write_field(str(tmp_path / ("m_%d.vti" % i)),
                         udvr.Field(m, list(origin), list(spacing), "f"))
    r = ref.RefMembers(members, origin, spacing)
    tf = refcase.random_tf(rng, float(members.min()), float(members.max()))
    tf.write(tmp_path / "tf.json")
    return rng, r, tf


def render_members(tmp_path, inputs, args, tag, kind="members"):
    npy = tmp_path / ("%s.npy" % tag)
    refcase.run_udvr("render", *inputs, "--model", kind, "--tf", tmp_path / "tf.json",
                     "--size", "%dx%d" % (W, H), "--float", npy, "-o", tmp_path / ("%s.png" % tag),
                     *args)
    img = np.load(npy)
    assert img.shape == (H, W, 4) and img.dtype == np.float32
    return img.astype(float)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("seed", [1201, 1202])
@pytest.mark.parametrize("camera", ["perspective", "default-parallel"])
def test_members_render_matches_reference(tmp_path, seed, camera, kind):
    rng, r, tf = random_ensemble(seed, tmp_path)
    args, cam, ps = refcase.random_camera(rng, r, camera)
    # A short unit distance: dense enough that compositing is far from linear in α.
    unit = 0.1 * r.spacing.min()
    args += ["--unit-distance", repr(unit)]
    got = render_members(tmp_path, [tmp_path / "ens.nc"], args, "nc", kind)
    want = ref.render(r, kind, tf, W, H, cam, parallel_scale=ps, unit=unit)
    diff = np.abs(got - want)
    assert diff.max() <= TOL, "max |udvr − reference| %.3g" % diff.max()
    assert np.count_nonzero(want[..., 3] > 1e-3) > 0, "the volume is not in view"
    # Member files (a quoted glob) are the same ensemble: the same image.
    files = render_members(tmp_path, [tmp_path / "m_*.vti"], args, "glob", kind)
    assert np.abs(files - got).max() == 0.0
    # Python renders the same ensemble with the same options to the same floats: from a
    # udvr.Ensemble, its (members, z, y, x) array (origin 0: only the geometry differs, so it is
    # compared by its own CLI run below), the .nc path and a quoted glob (issue 35).
    tfo = udvr.TransferFunction.from_paraview(str(tmp_path / "tf.json"))
    options = {a[2:].replace("-", "_"): b for a, b in zip(args[::2], args[1::2])}
    ens = udvr.read_ensemble([str(tmp_path / "ens.nc")])
    for source in (ens, str(tmp_path / "ens.nc"), str(tmp_path / "m_*.vti")):
        py = udvr.render(source, kind, tfo, (W, H), **options)
        assert np.abs(py.astype(float) - got).max() == 0.0, type(source).__name__
    with pytest.raises(ValueError, match="pass the ensemble"):
        udvr.render(udvr.build(str(tmp_path / "ens.nc"), gmm=0), "members", tfo, (W, H),
                    **options)
    with pytest.raises(TypeError, match="model 'members' renders"):
        udvr.render(ens, "mean", tfo, (W, H))
    # The average of the members' own images is another thing, and the reference tells them
    # apart on this data by 10× the tolerance or more (so the comparison above checks that the
    # classification is averaged per sample).
    images = [ref.render(f, "mean", tf, W, H, cam, parallel_scale=ps, unit=unit)
              for f in r.fields]
    apart = np.abs(np.mean(images, axis=0) - want).max()
    assert apart > 10 * TOL, apart


@pytest.mark.parametrize("kind", KINDS)
def test_members_probe_matches_reference(tmp_path, kind):
    rng, r, tf = random_ensemble(1203, tmp_path)
    for p in ([1.25, 2.5, 3.75], [0.0, 3.0, 5.0], [4.0, 0.3, 0.6]):
        out = json.loads(refcase.run_udvr("probe", tmp_path / "ens.nc", "--model", kind,
                                          "--point", refcase.fmt(p), "--tf", tmp_path / "tf.json",
                                          "--json"))
        values = [f.mean_at(np.array([p]))[0] for f in r.fields]
        assert out["members"] == len(r.fields)
        np.testing.assert_allclose(out["member_values"], values, rtol=0, atol=1e-5)
        np.testing.assert_allclose([out["min"], out["mean"], out["max"]],
                                   [min(values), np.mean(values), max(values)], atol=1e-5)
        want = r.classify(kind, tf, np.array([p]))[0]
        np.testing.assert_allclose(out["expected_rgba"], want, rtol=0, atol=1e-6)


def test_members_needs_an_ensemble_and_keeps_to_the_memory_cap(tmp_path):
    random_ensemble(1204, tmp_path, n=3)
    t = tmp_path
    refcase.run_udvr("build", t / "ens.nc", "--gmm", "0", "-o", t / "model.vti")
    before = listing(t)
    tf = ["--tf", t / "tf.json"]
    cases = [
        (["render", t / "model.vti", "--model", "members", *tf, "-o", t / "x.png"],
         ["needs an ensemble", "model file"]),
        (["probe", t / "model.vti", "--model", "members", "--point", "1,1,1", *tf],
         ["needs an ensemble", "model file"]),
        (["render", t / "m_0.vti", "--model", "members", *tf, "-o", t / "x.png"],
         ["needs an ensemble", "single field"]),
        # 3 members × 120 points × 4 bytes = 1440 bytes ≈ 1.34e-6 GiB.
        (["render", t / "ens.nc", "--model", "members", "--memory-cap", "1e-6", *tf, "-o",
          t / "x.png"], ["--memory-cap", "1.34e-06 GiB", "3 members"]),
        (["render", t / "ens.nc", "--model", "members", "--memory-cap", "0", *tf, "-o",
          t / "x.png"], ["--memory-cap", "positive"]),
        (["render", t / "m_0.vti", t / "m_1.vti", "--model", "mean", *tf, "-o", t / "x.png"],
         ["one model or field", "--model members"]),
    ]
    for args, mentions in cases:
        assert_one_line_error(run_udvr(*args), *mentions)
    assert listing(t) == before
    # Under a cap that holds them, the same command renders.
    refcase.run_udvr("render", t / "ens.nc", "--model", "members", "--memory-cap", "2e-6", *tf,
                     "--size", "8x8", "-o", t / "ok.png")
