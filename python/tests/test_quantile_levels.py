"""Uneven quantile levels (paper §6; SPEC §7 `quantile_levels`; `build --quantile-levels`):
- build: boundaries at the given levels against NumPy (empirical: numpy's linear quantiles; kde:
  the inverse KDE CDF by bisection), the levels stored in the model's field data;
- even levels given explicitly reproduce today's models and images exactly (bit for bit);
- probe and render of random models with uneven levels against the NumPy reference (each
  quantile weighted by its mass t_j − t_{j−1}: Eq. 4's mean, Eq. 5's weights m_j/w_j, the
  quartile views over the boundaries at levels .25 and .75), 1D and with a TF2;
- errors: levels that do not increase, miss 0 or 1, or disagree with --quantiles; quartile
  views of levels without .25 or .75."""
import json

import numpy as np
import pytest

import reference as ref
import reference2d as ref2
import refcase
import test_reference2d_cli as t2cli
import test_reference_build as trb

udvr = pytest.importorskip("udvr")

LEVELS = [0.0, 0.02, 0.1, 0.25, 0.5, 0.75, 0.9, 0.98, 1.0]  # tail-heavy, q = 8, has .25/.75
LEVELS_TEXT = ",".join("%g" % t for t in LEVELS)
W, H = 40, 32


def test_empirical_build_at_uneven_levels_matches_numpy(tmp_path):
    rng = np.random.default_rng(5)
    mem = trb.random_members(rng, [4, 3, 5], 12)
    m = trb.build(tmp_path, mem, "--quantile-levels", LEVELS_TEXT)
    v = mem.astype(float)
    b = np.moveaxis(np.quantile(v, LEVELS, axis=0), 0, -1)
    np.testing.assert_allclose(m.array("quantiles"), b, rtol=0, atol=1e-5 * np.abs(v).max())
    assert m.quantile_count == 8
    np.testing.assert_allclose(m.quantile_levels, LEVELS, rtol=0, atol=0)


def test_kde_build_at_uneven_levels_matches_numpy(tmp_path):
    rng = np.random.default_rng(8)
    n = 9
    mem = trb.random_members(rng, [3, 3, 2], n)
    levels = [0.0, 0.1, 0.5, 0.7, 1.0]
    m = trb.build(tmp_path, mem, "--quantile-levels", ",".join(map(str, levels)), "--density",
                  "kde", "--bandwidth", "0.3")
    s = mem.astype(float).reshape(n, -1).T  # (V, n)
    eps = 1 / (2 * n)  # b_0 and b_q at the tails ε and 1 − ε
    probs = np.array([eps] + levels[1:-1] + [1 - eps])
    const = s.max(1) == s.min(1)
    b = trb.kde_quantiles(s, probs, np.full(len(s), 0.3))
    b = np.where(const[:, None], s[:, :1], b)
    got = m.array("quantiles").reshape(-1, len(levels))
    np.testing.assert_allclose(got, b, rtol=0, atol=1e-5 * np.abs(s).max())


def test_even_levels_given_explicitly_reproduce_the_default(tmp_path):
    rng = np.random.default_rng(9)
    mem = trb.random_members(rng, [6, 5, 4], 10)
    default = trb.build(tmp_path, mem, "--quantiles", "8")
    even = ",".join("%.17g" % (j / 8) for j in range(9))
    udvr.write_model(str(tmp_path / "default.vti"), default)
    explicit = trb.build(tmp_path, mem, "--quantile-levels", even)
    assert np.array_equal(default.array("quantiles"), explicit.array("quantiles"))
    tf = refcase.random_tf(rng, -2.0, 5.0)
    tf.write(tmp_path / "tf.json")
    for kind in ("quantile-range", "quantile-mean", "quartile-middle"):
        imgs = []
        for name in ("default.vti", "model.vti"):
            out = tmp_path / ("%s-%s.npy" % (kind, name))
            refcase.run_udvr("render", tmp_path / name, "--model", kind, "--tf",
                             tmp_path / "tf.json", "--size", "48x40", "--float", out, "-o",
                             str(out) + ".png")
            imgs.append(np.load(out))
        assert np.array_equal(imgs[0], imgs[1]), kind


@pytest.fixture(scope="module")
def uneven_case(tmp_path_factory):
    rng = np.random.default_rng(21)
    dims = [4, 5, 3]
    arrays = refcase.random_model_arrays(rng, dims)
    m, r = refcase.make_models(udvr, arrays, rng.uniform(-2, 2, 3), rng.uniform(0.5, 1.5, 3),
                               levels=LEVELS)
    d = tmp_path_factory.mktemp("levels")
    udvr.write_model(str(d / "model.vti"), m)
    lo, hi = r.data_range()
    tf = refcase.random_tf(rng, lo, hi)
    tf.write(d / "tf.json")
    return dict(rng=rng, dims=dims, ref=r, tf=tf, dir=d, model=d / "model.vti",
                tfpath=d / "tf.json")


def test_uneven_levels_travel_through_the_model_file(uneven_case):
    m = udvr.read_model(str(uneven_case["model"]))
    np.testing.assert_allclose(m.quantile_levels, LEVELS, rtol=0, atol=0)


@pytest.mark.parametrize("kind", ["quantile-range", "quantile-mean", "quantile-mean-mass",
                                  "quartile-lower", "quartile-middle", "quartile-upper"])
def test_probe_with_uneven_levels_matches_reference(uneven_case, kind):
    c = uneven_case
    points = refcase.random_points(c["rng"], c["dims"], 3)
    answers = refcase.probe_many(c["model"], c["tfpath"], kind, points)
    for p, got in zip(points, answers):
        want = c["ref"].classify(kind, c["tf"], p[None, :])[0]
        assert np.abs(np.asarray(got["expected_rgba"]) - want).max() <= 1e-4, (kind, p)
        np.testing.assert_allclose(got["levels"], LEVELS, rtol=0, atol=0)
    # The even-level answer differs: the levels are not ignored.
    even = ref.RefModel(c["ref"].mean, quantiles=c["ref"].quantiles, iqr=c["ref"].iqr,
                        origin=c["ref"].origin, spacing=c["ref"].spacing)
    diffs = [np.abs(even.classify(kind, c["tf"], p[None, :])[0]
                    - np.asarray(got["expected_rgba"])).max() for p, got in zip(points, answers)]
    assert max(diffs) > 1e-3, kind


@pytest.mark.parametrize("kind", ["quantile-range", "quantile-mean", "quartile-upper"])
def test_render_with_uneven_levels_matches_reference(uneven_case, kind):
    c = uneven_case
    r = c["ref"]
    cam = ref.default_camera(r.bounds)
    out = c["dir"] / ("%s.npy" % kind)
    refcase.run_udvr("render", c["model"], "--model", kind, "--tf", c["tfpath"], "--size",
                     "%dx%d" % (W, H), "--float", out, "-o", str(out) + ".png")
    got = np.load(out)
    want = ref.render(r, kind, c["tf"], W, H, cam)
    assert np.abs(got - want).max() <= 2e-4, kind


@pytest.mark.parametrize("kind", ["quantile-range", "quantile-mean"])
def test_tf2_probe_with_uneven_levels_matches_reference(uneven_case, kind):
    c = uneven_case
    rng = np.random.default_rng(33)
    tf2 = t2cli.random_tf2_for(rng, c["ref"])
    tf2.write_npy(c["dir"] / "tf2.npy")
    for p in refcase.random_points(rng, c["dims"], 3):
        got = json.loads(refcase.run_udvr("probe", c["model"], "--point", refcase.fmt(p),
                                          "--model", kind, "--tf2", c["dir"] / "tf2.npy",
                                          "--tf2-domain", tf2.domain_arg(), "--json"))
        want = ref2.classify2d(c["ref"], kind, tf2, p[None, :])[0]
        assert np.abs(np.asarray(got["expected_rgba"]) - want).max() <= 1e-4, (kind, p)


@pytest.mark.parametrize("args,message", [
    (["--quantile-levels", "0,0.5,0.4,1"], "strictly increasing"),
    (["--quantile-levels", "0.1,0.5,1"], "start at 0 and end at 1"),
    (["--quantile-levels", "0,0.5,0.9"], "start at 0 and end at 1"),
    (["--quantile-levels", "0,0.5,1", "--quantiles", "4"], "disagrees"),
    (["--quantile-levels", "0,nan,1"], "--quantile-levels"),
    (["--quantiles", "-1"], "out of range"),  # the other input-free checks come first too
    (["--gmm", "99"], "out of range"),
])
def test_bad_options_are_refused_before_reading(tmp_path, args, message):
    from conftest import run_udvr
    r = run_udvr("build", tmp_path / "missing.nc", *args, "-o", tmp_path / "m.vti")
    assert r.returncode != 0
    assert message in r.stderr and "missing.nc" not in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "m.vti").exists()


def test_quartile_view_needs_its_levels(tmp_path):
    rng = np.random.default_rng(4)
    arrays = refcase.random_model_arrays(rng, [3, 3, 3], q=4)
    m, _ = refcase.make_models(udvr, arrays, [0, 0, 0], [1, 1, 1],
                               levels=[0, 0.1, 0.5, 0.9, 1])
    udvr.write_model(str(tmp_path / "m.vti"), m)
    from conftest import run_udvr
    r = run_udvr("probe", tmp_path / "m.vti", "--point", "1,1,1", "--model", "quartile-lower",
                 "--json")
    assert r.returncode != 0 and "levels 0 and 0.25" in r.stderr, r.stderr


def test_python_build_with_levels_equals_the_cli_and_keeps_them_through_xarray(tmp_path):
    rng = np.random.default_rng(12)
    mem = trb.random_members(rng, [4, 3, 5], 12)
    cli = trb.build(tmp_path, mem, "--quantile-levels", LEVELS_TEXT)
    py = udvr.build(mem, gmm=0, quantile_levels=LEVELS, origin=[0.5, -1.0, 2.0],
                    spacing=[1.0, 0.5, 2.0], progress=False)
    assert np.array_equal(py.quantiles, cli.array("quantiles"))
    np.testing.assert_array_equal(py.quantile_levels, LEVELS)
    assert repr(py) == "<udvr.Model 4x3x5 voxels, q=8 (uneven levels), empirical, 12 samples " \
        "per voxel>"
    back = udvr.Model.from_xarray(py.to_xarray())
    np.testing.assert_array_equal(back.quantile_levels, LEVELS)
    with pytest.raises(ValueError, match="disagrees"):
        udvr.build(mem, quantiles=4, gmm=0, quantile_levels=LEVELS, progress=False)
