"""The SPEC §9 command line (`udvr probe --tf2`, `udvr render --tf2`) against the independent
NumPy reference of reference2d.py, on random models (small grids, random origin and spacing, ties
and point masses in the quantiles, zero standard deviations), random raster TF2s (7×5 points,
random straight colour and α with exact zeros, given as ASCII .vti, base64 .vti or .npy with
--tf2-domain; the x range around the data range, the y range from 0 to about 1.2× the largest
|μ_Y|, so that both clamp somewhere), random points (interior, faces, edges, corners, grid
points) and random cameras.

Skipped (with the reason) while `udvr render --help` / `udvr probe --help` do not mention --tf2.

Tolerances: expected_rgba 1e−5 absolute (float32 output) for every model but the fast gaussian
(SPEC §4: within 1e−3 of gaussian-exact, which is held to 1e−5; held to 3e−4, TOL_GAUSSIAN); the
gradient μ_Y and the mean and
standard deviation of G 1e−5 relative (plus 1e−5 × the largest |μ_Y| of the grid, the float32
rounding floor); render 1e−4 as the 1D render test; and a TF2 constant in y renders the 1D image
of the same TF within 1e−5 (SPEC §9: "exactly the 1D image")."""
import json
import subprocess

import numpy as np
import pytest

import model_table
import reference as ref
import reference2d as r2
import refcase

udvr = pytest.importorskip("udvr")

TOL = 1e-5
# SPEC §4/§9: the fast `gaussian` within 1e−3 of gaussian-exact (held to TOL here). Its tables
# measured 3.7e−5 here with share 0.65, radius 4.25; 9.7e−5 with share 0.8, radius 4.0 (since
# 2026-12-04, issue 33's speed): held to 3e−4 as in the unit tests (expected_tf2_fast_test.cpp).
TOL_GAUSSIAN = 3e-4
# The fast 2D forms with a reference here, held to TOL_GAUSSIAN instead of TOL (rows of the
# table: test_reference_coverage.py); `gaussian-exact` is held to TOL.
FAST_TOL = {"gaussian": TOL_GAUSSIAN}
TOL_RENDER = 1e-4
TOL_SAME_AS_1D = 1e-5
# The fast 2D forms (`uniform`, `gaussian`; expected_tf2_fast.h) against the exact 1D image:
# within their stated 1e−3 of the exact kernels per sample (docs/models.md).
TOL_FAST_1D = 1e-3
W_IMG, H_IMG = 12, 9
# Every model of the table with a 2D TF (udvr.models()) that reference2d evaluates; the others
# (reference2d.NO_REFERENCE, the uniform box splines) against Monte Carlo below.
KINDS = [k for k in model_table.model_file_names("2d") if k not in r2.NO_REFERENCE]

# Models of SPEC §9 without a 2D kernel yet (their cases are skipped; none today). Models without
# a 2D classification must say so: test_models_without_a_2d_kernel_say_so (the GMMs, which SPEC §9
# does not give one, and anything listed here).
NOT_YET = set()


def supported(kind):
    return kind not in NOT_YET
FORMATS = ["vti-ascii", "vti-binary", "npy"]


def _help_mentions_tf2(command):
    try:
        p = subprocess.run([refcase.udvr_binary(), command, "--help"], capture_output=True,
                           text=True, timeout=60)
    except OSError as e:
        return False, "udvr binary not runnable (%s)" % e
    if "--tf2" not in p.stdout + p.stderr:
        return False, "`udvr %s --help` does not mention --tf2 (SPEC §9 not implemented yet)" % (
            command)
    return True, ""


@pytest.fixture(scope="module")
def probe_cli():
    ok, why = _help_mentions_tf2("probe")
    if not ok:
        pytest.skip(why)


@pytest.fixture(scope="module")
def render_cli():
    ok, why = _help_mentions_tf2("render")
    if not ok:
        pytest.skip(why)


# ---- cases ----------------------------------------------------------------------------------

def random_model(rng, dims, d):
    arrays = refcase.random_model_arrays(rng, dims)
    origin = rng.uniform(-3, 3, 3)
    spacing = rng.uniform(0.5, 2.0, 3)
    m, r = refcase.make_models(udvr, arrays, origin, spacing)
    udvr.write_model(str(d / "model.vti"), m)
    return r


def random_tf2_for(rng, r):
    """7×5 raster; x range around the data range (sometimes inside it, sometimes beyond), y from
    0 to 0.6–1.3× the largest |μ_Y| on the grid."""
    lo, hi = r.data_range()
    R = hi - lo
    x0 = lo + R * rng.uniform(-0.2, 0.15)
    x1 = hi - R * rng.uniform(-0.2, 0.15)
    y1 = r2.gradient_magnitude_range(r) * rng.uniform(0.6, 1.3)
    return r2.random_tf2(rng, (x0, x1), (0.0, y1), 7, 5)


def write_tf2(t, d, fmt, tag="tf2"):
    """The TF2 in one of the SPEC §9 raster forms; returns the CLI arguments naming it."""
    if fmt == "npy":
        path = d / (tag + ".npy")
        t.write_npy(path)
        return ["--tf2", path, "--tf2-domain", t.domain_arg()]
    path = d / (tag + ("_b" if fmt == "vti-binary" else "") + ".vti")
    t.write_vti(path, binary=(fmt == "vti-binary"))
    return ["--tf2", path]


def probe_many(model, tf2_args, kind, points):
    from concurrent.futures import ThreadPoolExecutor

    def one(p):
        out = refcase.run_udvr("probe", model, "--point", refcase.fmt(p), "--model", kind,
                               *tf2_args, "--json")
        return json.loads(out)

    with ThreadPoolExecutor(max_workers=4) as ex:
        return list(ex.map(one, points))


def check_probe(r, t, kind, p, got):
    want = r2.probe2d(r, kind, t, p)
    assert got["model"] == kind
    np.testing.assert_allclose(got["point"], p, rtol=0, atol=1e-12)
    tol = FAST_TOL.get(kind, TOL)
    rgba = np.asarray(got["expected_rgba"], float)
    assert rgba.shape == (4,)
    diff = np.abs(rgba - want["expected_rgba"]).max()
    assert diff <= tol, "%s at %s: udvr %s, reference %s (|diff| %.3g)" % (
        kind, p.tolist(), rgba.tolist(), want["expected_rgba"].tolist(), diff)
    gscale = max(r2.gradient_magnitude_range(r), 1e-30)
    np.testing.assert_allclose(got["gradient"], want["gradient"], rtol=1e-5, atol=1e-5 * gscale,
                               err_msg="gradient μ_Y, %s at %s" % (kind, p.tolist()))
    gm = got["gradient_magnitude"]
    np.testing.assert_allclose(
        [gm["mean"], gm["stddev"]],
        [want["gradient_magnitude"]["mean"], want["gradient_magnitude"]["stddev"]],
        rtol=1e-5, atol=1e-5 * gscale, err_msg="gradient_magnitude, %s at %s" % (kind, p.tolist()))


# ---- probe ----------------------------------------------------------------------------------

@pytest.fixture(scope="module", params=[0, 1, 2])
def probe_case(request, tmp_path_factory):
    seed = 101 + request.param
    rng = np.random.default_rng(seed)
    dims = [int(rng.integers(3, 6)), int(rng.integers(3, 6)), int(rng.integers(2, 6))]
    d = tmp_path_factory.mktemp("probe2d_%d" % seed)
    r = random_model(rng, dims, d)
    t = random_tf2_for(rng, r)
    fmt = FORMATS[request.param % len(FORMATS)]
    return dict(ref=r, tf2=t, model=d / "model.vti", args=write_tf2(t, d, fmt), fmt=fmt,
                points=refcase.random_points(rng, dims, 3), dir=d, monte_carlo={})


@pytest.mark.parametrize("kind", KINDS)
def test_probe_tf2_matches_reference(probe_cli, probe_case, kind):
    if not supported(kind):
        pytest.skip("model %s has no 2D TF classification in this build yet" % kind)
    c = probe_case
    for p, got in zip(c["points"], probe_many(c["model"], c["args"], kind, c["points"])):
        check_probe(c["ref"], c["tf2"], kind, p, got)


def test_probe_tf2_the_three_raster_forms_agree(probe_cli, probe_case):
    """ASCII .vti, base64 .vti and .npy + --tf2-domain are the same TF2."""
    c = probe_case
    p = c["points"][0]
    answers = []
    for fmt in FORMATS:
        args = write_tf2(c["tf2"], c["dir"], fmt, tag="same")
        answers.append(probe_many(c["model"], args, "quantile-range", [p])[0])
    for a in answers[1:]:
        np.testing.assert_allclose(a["expected_rgba"], answers[0]["expected_rgba"], rtol=0,
                                   atol=1e-6)
    check_probe(c["ref"], c["tf2"], "quantile-range", p, answers[0])


def test_probe_tf2_zero_mean_gradient_uses_plus_x(probe_cli, tmp_path):
    """A constant mean field: μ_Y = 0, n̂ = +x (SPEC §9), so the quantile models' G is the x
    derivative of the boundary fields and the mean model's |μ_Y| = 0."""
    rng = np.random.default_rng(111)
    dims = [4, 3, 3]
    arrays = refcase.random_model_arrays(rng, dims)
    arrays["mean"] = np.full_like(arrays["mean"], 1.5)
    origin, spacing = rng.uniform(-1, 1, 3), rng.uniform(0.5, 2.0, 3)
    m, r = refcase.make_models(udvr, arrays, origin, spacing)
    udvr.write_model(str(tmp_path / "model.vti"), m)
    lo, hi = r.data_range()
    gx = np.abs(r2.grid_gradients(r.quantiles[..., -1], r.spacing)[..., 0]).max()
    t = r2.random_tf2(rng, (lo, hi), (-gx, gx), 7, 5)  # G may be negative here
    args = write_tf2(t, tmp_path, "vti-binary")
    pts = refcase.random_points(rng, dims, 2)
    for kind in ("mean", "gaussian", "quantile-range", "quantile-mean"):
        if not supported(kind):
            continue
        for p, got in zip(pts, probe_many(tmp_path / "model.vti", args, kind, pts)):
            assert np.abs(np.asarray(got["gradient"])).max() == 0.0
            want = r2.probe2d(r, kind, t, p)
            tol = TOL_GAUSSIAN if kind == "gaussian" else TOL
            assert np.abs(np.asarray(got["expected_rgba"]) - want["expected_rgba"]).max() <= tol, (
                kind, p, got["expected_rgba"], want["expected_rgba"])
            np.testing.assert_allclose(
                [got["gradient_magnitude"]["mean"], got["gradient_magnitude"]["stddev"]],
                [want["gradient_magnitude"]["mean"], want["gradient_magnitude"]["stddev"]],
                rtol=1e-5, atol=1e-5 * gx, err_msg=kind)


# ---- render ---------------------------------------------------------------------------------

def render_udvr(d, kind, tf_args, cam_args, tag):
    npy = d / ("%s_%s.npy" % (tag, kind))
    refcase.run_udvr("render", d / "model.vti", "--model", kind, *tf_args, "--size",
                     "%dx%d" % (W_IMG, H_IMG), "--float", npy, "-o",
                     d / ("%s_%s.png" % (tag, kind)), *cam_args)
    img = np.load(npy)
    assert img.shape == (H_IMG, W_IMG, 4), img.shape
    assert img.dtype == np.float32
    return img.astype(float)


def check_image(got, want, tol, what):
    diff = np.abs(got - want)
    worst = np.unravel_index(np.argmax(diff), diff.shape)
    assert diff.max() <= tol, "%s: max |diff| %.3g at (row, col, channel) %s: udvr %s, ref %s" % (
        what, diff.max(), worst, got[worst[:2]].tolist(), want[worst[:2]].tolist())


@pytest.mark.parametrize("seed", [121, 122])
@pytest.mark.parametrize("camera", ["perspective", "parallel", "default"])
def test_render_tf2_matches_reference(render_cli, tmp_path, seed, camera):
    rng = np.random.default_rng(seed + {"perspective": 0, "parallel": 10, "default": 20}[camera])
    r = random_model(rng, [5, 4, 6], tmp_path)
    t = random_tf2_for(rng, r)
    tf_args = write_tf2(t, tmp_path, FORMATS[(seed + len(camera)) % 3])
    cam_args, cam, ps = refcase.random_camera(rng, r, camera)
    covered = 0
    wants = {}  # one reference image per joint distribution (gaussian and gaussian-exact share)
    for kind in KINDS:
        if not supported(kind):
            continue
        got = render_udvr(tmp_path, kind, tf_args, cam_args, camera)
        dist = r2.MODELS[kind]
        if dist not in wants:
            wants[dist] = r2.render2d(r, kind, t, W_IMG, H_IMG, cam, parallel_scale=ps)
        want = wants[dist]
        check_image(got, want, TOL_RENDER, "%s camera, %s, TF2 %s" % (camera, kind, tf_args[1]))
        covered += np.count_nonzero(want[..., 3] > 1e-3)
    assert covered > 0, "the volume is not in view: the test checks nothing"


def test_render_tf2_explicit_step_unit_early_exit_background(render_cli, tmp_path):
    rng = np.random.default_rng(131)
    r = random_model(rng, [5, 4, 6], tmp_path)
    t = random_tf2_for(rng, r)
    tf_args = write_tf2(t, tmp_path, "npy")
    cam_args, cam, ps = refcase.random_camera(rng, r, "perspective")
    step, unit = 0.37 * r.spacing.min(), rng.uniform(0.3, 2.0)
    early, bg = rng.uniform(0.3, 0.8), rng.uniform(0, 1, 3)
    cam_args += ["--step", repr(step), "--unit-distance", repr(unit), "--early-exit",
                 repr(early), "--background", refcase.fmt(bg)]
    for kind in ("mean", "gaussian", "quantile-mean"):
        if not supported(kind):
            continue
        got = render_udvr(tmp_path, kind, tf_args, cam_args, "explicit")
        want = r2.render2d(r, kind, t, W_IMG, H_IMG, cam, parallel_scale=ps, step=step,
                           unit=unit, early_exit=early, background=bg)
        check_image(got, want, TOL_RENDER, "explicit options, %s" % kind)


@pytest.mark.parametrize("kind", ["mean", "gaussian", "gaussian-exact", "quantile-range",
                                  "quantile-mean", "uniform", "uniform-exact"])
def test_render_tf2_constant_in_y_is_the_1d_render(render_cli, tmp_path, kind):
    """SPEC §9: a TF2 constant in y gives exactly the 1D image of §4 (the 1D TF with control
    points at the raster's columns, clamped outside the same range). `uniform-exact` takes X's
    box spline exactly, so it gives the exact 1D `uniform-exact` image; `uniform` (the fast 2D
    form) is within its stated error of that image (TOL_FAST_1D), as is the fast `gaussian`;
    reference2d has no uniform, so both uniforms are checked against the 1D render only."""
    if not supported(kind):
        pytest.skip("model %s has no 2D TF classification in this build yet" % kind)
    rng = np.random.default_rng(141)
    r = random_model(rng, [5, 4, 6], tmp_path)
    lo, hi = r.data_range()
    R = hi - lo
    Wt = 9
    rgb = rng.uniform(0, 1, (Wt, 3)).astype(np.float32).astype(float)
    al = (rng.uniform(0, 1, Wt) * (rng.random(Wt) > 0.2)).astype(np.float32).astype(float)
    t2, tf1 = r2.TF2.from_1d(rgb, al, lo + 0.1 * R, hi - 0.1 * R, 0.0,
                             1.1 * r2.gradient_magnitude_range(r), H=4)
    tf1.write(tmp_path / "tf.json")
    tf2_args = write_tf2(t2, tmp_path, "vti-ascii")
    cam_args, cam, ps = refcase.random_camera(rng, r, "default")
    got2 = render_udvr(tmp_path, kind, tf2_args, cam_args, "tf2")
    kind1 = {"uniform": "uniform-exact", "gaussian": "gaussian-exact"}.get(kind, kind)
    got1 = render_udvr(tmp_path, kind1, ["--tf", tmp_path / "tf.json"], cam_args, "tf1")
    assert got1[..., 3].max() > 1e-3, "the volume is not in view"
    tol = TOL_FAST_1D if kind in ("uniform", "gaussian") else TOL_SAME_AS_1D
    check_image(got2, got1, tol, "%s: --tf2 constant in y vs --tf" % kind)
    if kind.startswith("uniform"):
        return
    want = r2.render2d(r, kind.replace("-exact", ""), t2, W_IMG, H_IMG, cam, parallel_scale=ps)
    check_image(got2, want, TOL_RENDER, "%s: --tf2 constant in y vs reference" % kind)


def test_models_without_a_2d_kernel_say_so(probe_cli, tmp_path):
    rng = np.random.default_rng(5)
    r = random_model(rng, [3, 3, 3], tmp_path)
    args = write_tf2(random_tf2_for(rng, r), tmp_path, "npy")
    without = set(model_table.model_file_names("1d", probe=True)) - set(model_table.names("2d"))
    assert without, "the table has no model without a 2D kernel: nothing to check"
    for kind in sorted(NOT_YET | without):
        p = subprocess.run([str(refcase.udvr_binary()), "probe", str(tmp_path / "model.vti"),
                            "--point", "1,1,1", "--model", kind, *[str(a) for a in args],
                            "--json"], capture_output=True, text=True)
        assert p.returncode != 0, kind
        assert "has no 2D transfer-function classification yet" in p.stderr, p.stderr
        assert len(p.stderr.strip().splitlines()) == 1, p.stderr


# ---- uniform: the bivariate box spline (SPEC §9), against Monte Carlo ------------------------

# `uniform-exact` is the converged evaluation (expected_tf2_uniform_exact.h; within 1e−6 of the
# exact value, checked by refinement, docs/models.md); `uniform` (alias `uniform-fast`) is the
# fast form (issue 33, expected_tf2_fast.h), within 1e−3 of `uniform-exact` (docs/models.md).
# Against 4·10⁶-draw Monte Carlo on these 21 points: `uniform-exact` max |Δ| 1.8e−4 (1e6 draws:
# 3.9e−4; both the Monte Carlo noise, which halves with 4× the draws). Both are checked at 2·10⁶
# draws (noise ≈ 2e−4 at most here): `uniform-exact` to 6e−4, `uniform` to its 1e−3 plus that.
TOL_UNIFORM_MC = {"uniform-exact": 6e-4, "uniform": 1.6e-3, "uniform-fast": 1.6e-3}
MC_DRAWS = {"uniform-exact": 2_000_000, "uniform": 2_000_000, "uniform-fast": 2_000_000}


def uniform_monte_carlo(r, t, p, seed, draws=1_000_000):
    """E[(α·c, α)] over (X, G) = Σ_i (w_i, u_i) X_i, X_i ~ U[μ_i ± √3σ_i] independent."""
    S = r2.Sample2D(r, np.asarray(p, float)[None])
    w, u = S.w[0], S.u[0]
    h = np.sqrt(3.0) * r.stddev.ravel()[S.idx[0]]
    mu = r.mean.ravel()[S.idx[0]]
    cx, cy = float(w @ mu), float(u @ mu)
    rng = np.random.default_rng(seed)
    acc = np.zeros(4)
    chunk = 200_000
    for _ in range(draws // chunk):
        tt = rng.uniform(-1.0, 1.0, (chunk, len(w))) * h
        acc += t(cx + tt @ w, cy + tt @ u).sum(0)
    return acc / draws, cy, float(np.sqrt(np.sum((u * h) ** 2) / 3.0))


@pytest.mark.parametrize("kind", ["uniform", "uniform-exact"])
def test_probe_tf2_uniform_reports_its_box_spline(probe_cli, probe_case, kind):
    """`probe --json --tf2` of the 2D uniform gives its box spline (SPEC §9): center (x̄, μ_G)
    and one direction (w_i, u_i)·√3σ_i per voxel of the 32-voxel form, as the NumPy
    reference builds them (directions compared as sets, zero ones left out)."""
    c = probe_case
    for p, got in zip(c["points"], probe_many(c["model"], c["args"], kind, c["points"])):
        S = r2.Sample2D(c["ref"], np.asarray(p, float)[None])
        h = np.sqrt(3.0) * c["ref"].stddev.ravel()[S.idx[0]]
        want = np.stack([S.w[0] * h, S.u[0] * h], axis=1)
        box = got["box_spline"]
        have = np.asarray(box["directions"], float).reshape(-1, 2)
        scale = np.abs(want).max(axis=0) + 1e-30
        key = lambda d: d[np.lexsort(((d / scale)[:, 1].round(6), (d / scale)[:, 0].round(6)))]
        keep = lambda d: d[np.abs(d / scale).max(axis=1) > 1e-9]
        have, want = key(keep(have)), key(keep(want))
        assert have.shape == want.shape, "%s at %s: %d directions, the reference %d" % (
            kind, p.tolist(), len(have), len(want))
        np.testing.assert_allclose(have / scale, want / scale, rtol=0, atol=1e-5,
                                   err_msg="%s at %s: directions" % (kind, p.tolist()))
        gm = float(np.dot(S.nhat[0], S.mu_y[0]))
        np.testing.assert_allclose(box["center"], [float(S.xbar[0]), gm], rtol=1e-5,
                                   atol=1e-5 * scale.max(), err_msg="%s at %s: center" % (
                                       kind, p.tolist()))


@pytest.mark.parametrize("kind", sorted(r2.NO_REFERENCE))
def test_probe_tf2_uniform_matches_monte_carlo(probe_cli, probe_case, kind):
    c = probe_case
    for k, (p, got) in enumerate(zip(c["points"],
                                     probe_many(c["model"], c["args"], kind, c["points"]))):
        # One estimate per point and draw count, shared by the kinds (the same distribution).
        key = (k, MC_DRAWS[kind])
        if key not in c["monte_carlo"]:
            c["monte_carlo"][key] = uniform_monte_carlo(c["ref"], c["tf2"], p, 900 + k,
                                                        MC_DRAWS[kind])
        want, g_mean, g_std = c["monte_carlo"][key]
        diff = np.abs(np.asarray(got["expected_rgba"]) - want).max()
        assert diff <= TOL_UNIFORM_MC[kind], "%s at %s: udvr %s, Monte Carlo %s (|diff| %.3g)" % (
            kind, p.tolist(), got["expected_rgba"], want.tolist(), diff)
        gscale = max(r2.gradient_magnitude_range(c["ref"]), 1e-30)
        gm = got["gradient_magnitude"]
        np.testing.assert_allclose([gm["mean"], gm["stddev"]], [g_mean, g_std], rtol=1e-5,
                                   atol=1e-5 * gscale)
