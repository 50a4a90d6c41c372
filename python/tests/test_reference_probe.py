"""`udvr probe --json` against the independent NumPy reference of SPEC §3–§4 (reference.py) on
random models (small grids, random spacing and origin, ties and point masses in the quantiles),
random TFs (steps, zero opacity, control points beyond the data range) and random points
(interior, faces, edges, corners). Every model of the model table (udvr.models()) that probes a
model file: all but gmm-mc (no distribution at a point) and members (an ensemble:
test_reference_members.py). Tolerance 1e−4 absolute, the SPEC's accuracy for the expected TF,
but for the fast forms (FAST_TOL)."""
import numpy as np
import pytest

import model_table
import reference as ref
import refcase

udvr = pytest.importorskip("udvr")

TOL = 1e-4
MODELS = model_table.model_file_names("1d", probe=True)
FAST_TOL = model_table.FAST_TOL_1D  # the fast forms: their documented error
SEEDS = [11, 12, 13, 14]


@pytest.fixture(scope="module", params=SEEDS)
def case(request, tmp_path_factory):
    rng = np.random.default_rng(request.param)
    dims = [int(rng.integers(3, 6)), int(rng.integers(3, 6)), int(rng.integers(2, 5))]
    arrays = refcase.random_model_arrays(rng, dims)
    origin = rng.uniform(-3, 3, 3)
    spacing = rng.uniform(0.5, 2.0, 3)
    m, r = refcase.make_models(udvr, arrays, origin, spacing)
    d = tmp_path_factory.mktemp("probe%d" % request.param)
    udvr.write_model(str(d / "model.vti"), m)
    lo, hi = r.data_range()
    tf = refcase.random_tf(rng, lo, hi)
    tf.write(d / "tf.json")
    return dict(rng=rng, dims=dims, ref=r, tf=tf, model=d / "model.vti", tfpath=d / "tf.json",
                points=refcase.random_points(rng, dims, 3))


@pytest.mark.parametrize("kind", MODELS)
def test_probe_matches_reference(case, kind):
    r, tf = case["ref"], case["tf"]
    answers = refcase.probe_many(case["model"], case["tfpath"], kind, case["points"])
    for p, got in zip(case["points"], answers):
        assert got["model"] == kind
        np.testing.assert_allclose(got["point"], p, rtol=0, atol=1e-12)
        dist = ref.MODELS[kind]  # the distribution the reference evaluates for it
        want = r.classify(kind, tf, p[None, :])[0]
        diff = np.abs(np.asarray(got["expected_rgba"]) - want).max()
        assert diff <= FAST_TOL.get(kind, TOL), (
            "%s at %s: udvr %s, reference %s (|diff| %.3g)" % (kind, p, got["expected_rgba"],
                                                              want.tolist(), diff))
        scale = max(1.0, abs(r.data_range()[0]), abs(r.data_range()[1]))
        if "value" in got:
            assert abs(got["value"] - r.mean_at(p[None, :])[0]) <= 1e-5 * scale
        if dist == "gaussian":
            mu, sg = r.gaussian_at(p[None, :])
            assert abs(got["mean"] - mu[0]) <= 1e-5 * scale
            assert abs(got["stddev"] - sg[0]) <= 1e-5 * scale
        if dist.startswith("quantile") or dist.startswith("quartile") or dist == "iqr":
            b = r.boundaries_at(p[None, :], "iqr" if dist == "iqr" else "quantiles")[0]
            np.testing.assert_allclose(got["boundaries"], b, rtol=0, atol=1e-5 * scale)
        if dist == "uniform":  # X = Σ w_c U[μ_c − √3σ_c, μ_c + √3σ_c]
            mu, sg = r.gaussian_at(p[None, :])  # same mean and variance as the Gaussian
            assert abs(got["mean"] - mu[0]) <= 1e-5 * scale
            assert abs(got["stddev"] - sg[0]) <= 1e-5 * scale
            idx, w = r.corners(p[None, :])
            half = np.sum(w * ref.SQRT3 * r.stddev.ravel()[idx])
            assert abs(got["low"] - (mu[0] - half)) <= 1e-5 * scale
            assert abs(got["high"] - (mu[0] + half)) <= 1e-5 * scale
        if dist in ("quantile-mean", "quantile-mean-mass"):
            b = r.boundaries_at(p[None, :])[0]
            np.testing.assert_allclose(got["midpoints"], 0.5 * (b[1:] + b[:-1]), rtol=0,
                                       atol=1e-5 * scale)
            assert abs(sum(got["probabilities"]) - 1) <= 1e-9
        if dist == "gmm-ordered":
            idx, w = r.corners(p[None, :])
            par = r._lerp(r.gmm, idx, w)[0]
            K = len(par) // 3
            for key, sl in (("weights", par[:K]), ("means", par[K:2 * K]),
                            ("sigmas", par[2 * K:])):
                np.testing.assert_allclose(got[key], sl, rtol=0, atol=1e-5 * scale)


def test_probe_constant_tf_is_exact(tmp_path):
    """A constant TF gives the constant for every model (the distribution integrates to 1)."""
    rng = np.random.default_rng(5)
    arrays = refcase.random_model_arrays(rng, [3, 4, 2])
    m, r = refcase.make_models(udvr, arrays, [0, 0, 0], [1, 1, 1])
    udvr.write_model(str(tmp_path / "m.vti"), m)
    tf = ref.TF([0.0], [[0.2, 0.4, 0.6]], [0.0], [0.5])
    tf.write(tmp_path / "tf.json")
    for kind in MODELS:
        got = refcase.probe_json(tmp_path / "m.vti", tmp_path / "tf.json", kind, [1.3, 2.2, 0.6])
        np.testing.assert_allclose(got["expected_rgba"], [0.1, 0.2, 0.3, 0.5], rtol=0, atol=1e-6,
                                   err_msg=kind)


def test_probe_uniform_minmax_matches_reference(tmp_path):
    """`--uniform-width minmax`: X = Σ w_c U[min_c, max_c] (SPEC §2)."""
    rng = np.random.default_rng(15)
    arrays = refcase.random_model_arrays(rng, [4, 3, 3])
    m, r = refcase.make_models(udvr, arrays, rng.uniform(-1, 1, 3), rng.uniform(0.5, 2, 3))
    udvr.write_model(str(tmp_path / "m.vti"), m)
    tf = refcase.random_tf(rng, *r.data_range())
    tf.write(tmp_path / "tf.json")
    pts = refcase.random_points(rng, [4, 3, 3], 3)
    answers = refcase.probe_many(tmp_path / "m.vti", tmp_path / "tf.json", "uniform-exact", pts,
                                 ("--uniform-width", "minmax"))
    for p, a in zip(pts, answers):
        got = np.asarray(a["expected_rgba"])
        want = r.classify("uniform", tf, p[None, :], uniform_width="minmax")[0]
        assert np.abs(got - want).max() <= TOL, (p, got, want)


def test_probe_and_render_accept_the_same_uniform_width_names(tmp_path):
    rng = np.random.default_rng(16)
    arrays = refcase.random_model_arrays(rng, [3, 3, 3])
    m, r = refcase.make_models(udvr, arrays, [0, 0, 0], [1, 1, 1])
    udvr.write_model(str(tmp_path / "m.vti"), m)
    refcase.random_tf(rng, *r.data_range()).write(tmp_path / "tf.json")
    refcase.run_udvr("probe", tmp_path / "m.vti", "--point", "1,1,1", "--model", "uniform",
                     "--tf", tmp_path / "tf.json", "--uniform-width", "variance")
    refcase.run_udvr("render", tmp_path / "m.vti", "--model", "uniform", "--tf",
                     tmp_path / "tf.json", "--size", "4x3", "--uniform-width", "std", "-o",
                     tmp_path / "u.png")


@pytest.mark.parametrize("density", ["empirical", "kde"])
def test_probe_a_built_model_matches_reference(tmp_path, density):
    """End to end: members → `udvr build` (GMM by EM, quantiles) → probe, against the reference
    on the arrays udvr wrote."""
    rng = np.random.default_rng(17)
    dims = [4, 3, 3]
    for i in range(6):
        v = rng.normal(0, 1, dims[::-1]) + (rng.random(dims[::-1]) < 0.3) * 3.0
        udvr.write_field(str(tmp_path / ("m%d.vti" % i)),
                         udvr.Field(v.astype(np.float32), [1.0, 2.0, 3.0], [0.5, 1.0, 1.5]))
    refcase.run_udvr("build", *sorted(tmp_path.glob("m*.vti")), "--gmm", "2", "--density",
                     density, "-o", tmp_path / "model.vti")
    m = udvr.read_model(str(tmp_path / "model.vti"))
    r = ref.RefModel(m.array("mean"), stddev=m.array("stddev"), vmin=m.array("min"),
                     vmax=m.array("max"), quantiles=m.array("quantiles"), iqr=m.array("iqr"),
                     gmm=m.array("gmm"), origin=m.grid.origin, spacing=m.grid.spacing)
    tf = refcase.random_tf(rng, *r.data_range())
    tf.write(tmp_path / "tf.json")
    pts = refcase.random_points(rng, dims, 2)
    for kind in ["gmm-ordered", "quantile-mean", "quantile-range", "iqr", "gaussian"]:
        for p, got in zip(pts, refcase.probe_many(tmp_path / "model.vti", tmp_path / "tf.json",
                                                  kind, pts)):
            want = r.classify(kind, tf, p[None, :])[0]
            assert np.abs(np.asarray(got["expected_rgba"]) - want).max() <= TOL, (kind, p)
