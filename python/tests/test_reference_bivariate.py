"""Bivariate fields with a 2D TF (SPEC §9 `--second`, fuzzy fiber surfaces).

First reference_bivariate.py against Monte Carlo (10⁶ draws of each field from its model of
SPEC §3, the two fields independent; tolerance 2e−3), then `udvr probe --tf2 --second --json`
and `udvr render --tf2 --second --float` against reference_bivariate.py on random model pairs
(random origin and spacing, ties, point masses, zero standard deviations), random raster TF2s
(7×5, x and y ranges around each field's data range so that both clamp) and random cameras:
expected_rgba within 1e−5 (float32 output), the second field's mean and standard deviation 1e−5
relative, images within 1e−4 (the 1D render tests' tolerance). A second field that is constant
renders the 1D image of the first (TF2 sampled along that constant's row) within 1e−5."""
import json
import subprocess

import numpy as np
import pytest

import reference as ref
import reference2d as r2
import model_table
import reference_bivariate as rb
import refcase

udvr = pytest.importorskip("udvr")

# Every model of the table (udvr.models()) with bivariate fields that reads a model file (members:
# test_members_matches_reference, from ensembles) and that reference_bivariate evaluates.
KINDS = [k for k in model_table.model_file_names("bivariate") if k not in rb.NO_REFERENCE]
# Their distributions (aliases and exact forms share one): what the reference's own checks run.
DISTRIBUTIONS = sorted({rb.MODELS[k] for k in KINDS})
# Models checked by probe only (test_probe_second_matches_reference at TOL), not by image, with
# why. test_reference_coverage.py checks that they are rows of the table and probed.
_SLOW = ("the reference's {} rule per field and sample (tensor product of the two fields' "
         "rules) takes {} for one 12×9 image (load 8–11 on 2 cores), against 0.35–0.6 s for the "
         "mean and the quantile models")
PROBE_ONLY = dict(
    {k: _SLOW.format("normal", "44 s") for k in ("gaussian", "gaussian-exact")},
    **{"gmm-ordered": _SLOW.format("normal (one per component, K = 3 here)",
                                   "about K × gaussian's (not measured)")},
    **{k: _SLOW.format("box spline", "over 200 s") for k in ("uniform", "uniform-fast",
                                                             "uniform-exact")})
RENDER_KINDS = [k for k in KINDS if k not in PROBE_ONLY]
TOL = 1e-5
TOL_RENDER = 1e-4
N_MC = 1_000_000
MC_TOL = 2e-3


def random_pair(seed, dims):
    rng = np.random.default_rng(seed)
    origin, spacing = rng.uniform(-3, 3, 3), rng.uniform(0.5, 2.0, 3)
    pair = []
    for _ in range(2):
        a = refcase.random_model_arrays(rng, dims)
        pair.append((a, refcase.make_models(udvr, a, origin, spacing)))
    return rng, pair


def tf2_over(rng, r1, r2_, W=7, H=5):
    """x over the first field's data range, y over the second's, each a little inside or beyond
    it (clamping on some sides)."""
    (a0, a1), (b0, b1) = r1.data_range(), r2_.data_range()
    ra, rb_ = a1 - a0, b1 - b0
    return r2.random_tf2(rng, (a0 + ra * rng.uniform(-0.1, 0.2), a1 - ra * rng.uniform(-0.1, 0.2)),
                         (b0 + rb_ * rng.uniform(-0.1, 0.2), b1 - rb_ * rng.uniform(-0.1, 0.2)),
                         W, H, zero_frac=0.2)


# ---- the reference against Monte Carlo --------------------------------------------------------

def draw_field(m, kind, p, rng, n):
    """n draws of the field's value at p from its model (SPEC §3), independently of the rule."""
    p2 = np.atleast_2d(p)
    if kind == "members":  # one member at random, interpolated as a mean field
        values = np.array([f.mean_at(p2)[0] for f in m.fields])
        return values[rng.integers(len(values), size=n)]
    idx, w = m.corners(p2)
    idx, w = idx[0], w[0]
    lo, hi = m.data_range()
    if kind == "mean":
        return np.full(n, m.mean_at(p2)[0])
    if kind == "gaussian":
        mu, sg = m.gaussian_at(p2)
        return mu[0] + sg[0] * rng.standard_normal(n)
    if kind == "uniform":
        mc, sc = m.mean.ravel()[idx], m.stddev.ravel()[idx]
        u = rng.random((n, len(idx)))
        return ((mc - ref.SQRT3 * sc) + 2 * ref.SQRT3 * sc * u) @ w
    if kind == "gmm-ordered":
        K = m.gmm.shape[-1] // 3
        par = m.gmm.reshape(-1, 3 * K)[idx].T @ w
        pi, mu, sg = par[:K] / par[:K].sum(), par[K:2 * K], par[2 * K:]
        k = rng.choice(K, n, p=pi)
        return mu[k] + sg[k] * rng.standard_normal(n)
    if kind in rb.QUANTILE_RANGE_KINDS:
        B = m.boundaries_at(p2, "iqr" if kind == "iqr" else "quantiles")[0]
        q = len(B) - 1
        t0, t1 = {"quantile-range": (0, 1), "iqr": (0, 1), "quartile-middle": (0.25, 0.75),
                  "quartile-lower": (0, 0.25), "quartile-upper": (0.75, 1)}[kind]
        return np.interp(rng.uniform(t0, t1, n), np.arange(q + 1) / q, B)
    if kind in ("quantile-mean", "quantile-mean-mass"):
        B = m.boundaries_at(p2)[0]
        wq = np.diff(B)
        zero = wq <= ref.ZERO_WIDTH * (hi - lo)
        pw = (np.ones_like(wq) if kind == "quantile-mean-mass"
              else zero.astype(float) if zero.any() else 1.0 / wq)
        j = rng.choice(len(wq), n, p=pw / pw.sum())
        return 0.5 * (B[j] + B[j + 1])
    raise ValueError(kind)


@pytest.mark.parametrize("kind", DISTRIBUTIONS)
def test_reference_against_monte_carlo(kind):
    rng, pair = random_pair(71, [4, 3, 3])
    (_, (_, m1)), (_, (_, m2)) = pair
    for p in [np.array([1.3, 0.6, 1.2]), np.array([3.0, 2.0, 0.4])]:
        X = draw_field(m1, kind, p, rng, N_MC)
        Y = draw_field(m2, kind, p, rng, N_MC)
        # A raster the scale of the spread of (X, Y) (clamping a little on every side).
        (xa, xb), (ya, yb) = np.percentile(X, [2, 98]), np.percentile(Y, [2, 98])
        if xb - xa < 1e-6:
            xa, xb = xa - 1, xb + 1
        if yb - ya < 1e-6:
            ya, yb = ya - 1, yb + 1
        t = r2.random_tf2(rng, (xa, xb), (ya, yb), 7, 5, zero_frac=0.1)
        want = t(X, Y).mean(0)
        got = rb.classify_bivariate(m1, m2, kind, t, p[None, :])[0]
        assert np.abs(got - want).max() <= MC_TOL, (kind, p, got, want)
        mean, sd = rb.field_moments(m2, kind, p)
        np.testing.assert_allclose([mean, sd], [Y.mean(), Y.std()], rtol=0,
                                   atol=5e-3 * (Y.std() + 1e-9))


def test_reference_with_a_constant_second_field_is_the_1d_classification():
    """TF2 constant in y → the first field's 1D classification (reference.py), every model."""
    rng, pair = random_pair(72, [4, 3, 3])
    (_, (_, m1)), (_, (_, m2)) = pair
    lo, hi = m1.data_range()
    Wt = 9
    rgb = rng.uniform(0, 1, (Wt, 3))
    al = rng.uniform(0, 1, Wt) * (rng.random(Wt) > 0.2)
    t2, tf1 = r2.TF2.from_1d(rgb, al, lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo), *m2.data_range())
    pts = np.array([[1.3, 0.6, 1.2], [0.0, 2.0, 2.0], [2.5, 1.0, 0.5]])
    for kind in DISTRIBUTIONS:
        got = rb.classify_bivariate(m1, m2, kind, t2, pts)
        want = m1.classify(kind, tf1, pts)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9, err_msg=kind)


# ---- the command line against the reference --------------------------------------------------

@pytest.fixture(scope="module")
def case(tmp_path_factory):
    rng, pair = random_pair(73, [4, 5, 3])
    d = tmp_path_factory.mktemp("bivariate")
    (a1, (u1, m1)), (a2, (u2, m2)) = pair
    udvr.write_model(str(d / "first.vti"), u1)
    udvr.write_model(str(d / "second.vti"), u2)
    t = tf2_over(rng, m1, m2)
    t.write_vti(d / "tf2.vti")
    return dict(dir=d, m1=m1, m2=m2, tf2=t, points=refcase.random_points(rng, [4, 5, 3], 3),
                rng=rng)


def probe(d, kind, p, *extra):
    out = refcase.run_udvr("probe", d / "first.vti", "--point", refcase.fmt(p), "--model", kind,
                           "--tf2", d / "tf2.vti", "--second", d / "second.vti", "--json", *extra)
    return json.loads(out)


@pytest.mark.parametrize("kind", KINDS)
def test_probe_second_matches_reference(case, kind):
    from concurrent.futures import ThreadPoolExecutor
    d = case["dir"]
    with ThreadPoolExecutor(max_workers=4) as ex:
        got_all = list(ex.map(lambda p: probe(d, kind, p), case["points"]))
    for p, got in zip(case["points"], got_all):
        want = rb.classify_bivariate(case["m1"], case["m2"], kind, case["tf2"], p[None, :])[0]
        rgba = np.asarray(got["expected_rgba"], float)
        assert np.abs(rgba - want).max() <= TOL, (kind, p.tolist(), rgba.tolist(), want.tolist())
        mean, sd = rb.field_moments(case["m2"], kind, p)
        scale = np.ptp(case["m2"].data_range())
        np.testing.assert_allclose([got["second"]["mean"], got["second"]["stddev"]], [mean, sd],
                                   rtol=1e-5, atol=1e-6 * scale, err_msg=kind)
        assert got["gradient_magnitude"] == {"mean": got["second"]["mean"],
                                             "stddev": got["second"]["stddev"]}
        np.testing.assert_allclose(got["second"]["value"], case["m2"].mean_at(p[None, :])[0],
                                   rtol=1e-6, atol=1e-6 * scale)


def render(d, kind, tag, cam_args, second="second.vti", tf=("--tf2", "tf2.vti"), size=(12, 9)):
    npy = d / ("%s_%s.npy" % (tag, kind))
    args = [a if not str(a).endswith((".vti", ".json")) else d / a for a in tf]
    if second:
        args += ["--second", d / second]
    refcase.run_udvr("render", d / "first.vti", "--model", kind, *args, "--size",
                     "%dx%d" % size, "--float", npy, "-o", d / ("%s_%s.png" % (tag, kind)),
                     *cam_args)
    return np.load(npy).astype(float)


@pytest.mark.parametrize("camera", ["perspective", "default-parallel"])
def test_render_second_matches_reference(case, camera):
    rng = np.random.default_rng(74 + len(camera))
    cam_args, cam, ps = refcase.random_camera(rng, case["m1"], camera)
    covered = 0
    for kind in RENDER_KINDS:
        got = render(case["dir"], kind, camera, cam_args)
        want = rb.render_bivariate(case["m1"], case["m2"], kind, case["tf2"], 12, 9, cam,
                                   parallel_scale=ps)
        diff = np.abs(got - want)
        assert diff.max() <= TOL_RENDER, (kind, camera, diff.max())
        covered += np.count_nonzero(want[..., 3] > 1e-3)
    assert covered > 0, "the volume is not in view: the test checks nothing"


@pytest.mark.parametrize("kind", ["gaussian", "uniform", "quantile-range", "quantile-mean"])
def test_render_with_a_constant_second_field_is_the_1d_render(case, kind, tmp_path):
    """SPEC §9: a bivariate render whose second field is a constant c (no spread) is the 1D
    render of the first with TF(x) = TF2(x, c)."""
    d = case["dir"]
    rng = np.random.default_rng(75)
    (lo, hi), (b0, b1) = case["m1"].data_range(), case["m2"].data_range()
    c = b0 + 0.37 * (b1 - b0)
    shape = case["m1"].mean.shape
    const = dict(mean=np.full(shape, c, np.float32), stddev=np.zeros(shape, np.float32),
                 min=np.full(shape, c, np.float32), max=np.full(shape, c, np.float32),
                 quantiles=np.full(shape + (9,), c, np.float32),
                 iqr=np.full(shape + (2,), c, np.float32),
                 gmm=np.concatenate([np.ones(shape + (1,)), np.full(shape + (1,), c),
                                     np.zeros(shape + (1,))], -1).astype(np.float32))
    m, _ = refcase.make_models(udvr, const, case["m1"].origin, case["m1"].spacing)
    udvr.write_model(str(d / "constant.vti"), m)
    # The 1D TF with control points at the raster's columns: TF2's row interpolated at y = c.
    t = case["tf2"]
    rows = t.straight(t.xs, np.full(t.W, c))
    tf1 = ref.TF(t.xs, rows[:, :3], t.xs, rows[:, 3])
    tf1.write(d / "row.json")
    cam_args, _, _ = refcase.random_camera(rng, case["m1"], "default")
    got2 = render(d, kind, "const2d", cam_args, second="constant.vti")
    got1 = render(d, kind, "const1d", cam_args, second=None, tf=("--tf", "row.json"))
    assert got1[..., 3].max() > 1e-3, "the volume is not in view"
    assert np.abs(got2 - got1).max() <= 1e-5, (kind, np.abs(got2 - got1).max())


def test_bad_second_inputs_say_so(case, tmp_path):
    d = case["dir"]
    other = refcase.random_model_arrays(np.random.default_rng(76), [3, 3, 3])
    m, _ = refcase.make_models(udvr, other, [0, 0, 0], [1, 1, 1])
    udvr.write_model(str(tmp_path / "small.vti"), m)
    cases = [
        (["--second", tmp_path / "small.vti", "--tf2", d / "tf2.vti"], "need one grid"),
        (["--second", d / "second.vti", "--tf", d / "row.json"], "needs --tf2"),
        (["--second-var", "mean", "--tf2", d / "tf2.vti"], "it needs --second"),
        (["--second", tmp_path / "missing.vti", "--tf2", d / "tf2.vti"], "missing.vti"),
    ]
    if not (d / "row.json").exists():
        ref.TF(np.array([0.0, 1.0]), np.zeros((2, 3)), np.array([0.0, 1.0]),
               np.array([0.0, 1.0])).write(d / "row.json")
    for args, words in cases:
        for cmd in ("probe", "render"):
            extra = (["--point", "1,1,1", "--json"] if cmd == "probe"
                     else ["-o", tmp_path / "x.png", "--size", "8x8"])
            p = subprocess.run([str(refcase.udvr_binary()), cmd, str(d / "first.vti"), "--model",
                                "gaussian", *[str(a) for a in args], *[str(a) for a in extra]],
                               capture_output=True, text=True)
            assert p.returncode != 0, (cmd, args)
            assert words in p.stderr, (cmd, args, p.stderr)
            assert len(p.stderr.strip().splitlines()) == 1, p.stderr
    p = subprocess.run([str(refcase.udvr_binary()), "render", str(d / "first.vti"), "--model",
                        "gmm-mc", "--tf2", str(d / "tf2.vti"), "--second", str(d / "second.vti"),
                        "-o", str(tmp_path / "x.png"), "--size", "8x8"],
                       capture_output=True, text=True)
    assert p.returncode != 0 and "no bivariate classification" in p.stderr, p.stderr


# ---- members: two ensembles -------------------------------------------------------------------

def trilinear(values, p):
    """values (n, z, y, x) at the index point p = (i, j, k): each member's trilinear value."""
    n, nz, ny, nx = values.shape
    out = np.zeros(n)
    base = [min(int(np.floor(c)), d - 2) for c, d in zip(p, (nx, ny, nz))]
    f = [c - b for c, b in zip(p, base)]
    for dz in (0, 1):
        for dy in (0, 1):
            for dx in (0, 1):
                w = ((f[0] if dx else 1 - f[0]) * (f[1] if dy else 1 - f[1])
                     * (f[2] if dz else 1 - f[2]))
                out += w * values[:, base[2] + dz, base[1] + dy, base[0] + dx]
    return out


def test_members_bivariate_on_the_command_line_matches_the_reference_and_python(tmp_path):
    """--model members --tf2 --second: both inputs ensembles, each member a point mass 1/n of its
    field, the fields independent — E = mean over the member pairs of TF2(a_i, b_j); the CLI's
    probe against that, and its render and probe against Python's (issue 31)."""
    rng = np.random.default_rng(77)
    dims = [4, 5, 3]
    origin, spacing = rng.uniform(-3, 3, 3), rng.uniform(0.5, 2.0, 3)
    values = [rng.normal(0.0, 1.0, (n, dims[2], dims[1], dims[0])).astype(np.float32)
              for n in (5, 4)]
    paths = [tmp_path / "a.nc", tmp_path / "b.nc"]
    ensembles = []
    for v, path in zip(values, paths):
        e = udvr.Ensemble(v, origin, spacing)
        udvr.write_ensemble(str(path), e)
        ensembles.append(udvr.members_model(udvr.read_ensemble([str(path)])))
    t = r2.random_tf2(rng, (-2.0, 2.2), (-1.8, 2.0), zero_frac=0.2)
    t.write_vti(tmp_path / "tf2.vti")
    tf2 = udvr.TransferFunction2D.read(str(tmp_path / "tf2.vti"))
    for p in refcase.random_points(rng, dims, 3):
        out = refcase.run_udvr("probe", paths[0], "--point", refcase.fmt(p), "--model", "members",
                               "--tf2", tmp_path / "tf2.vti", "--second", paths[1], "--json")
        got = np.asarray(json.loads(out)["expected_rgba"], float)
        a, b = trilinear(values[0].astype(float), p), trilinear(values[1].astype(float), p)
        want = t(a[:, None], b[None, :]).reshape(-1, 4).mean(0)
        assert np.abs(got - want).max() <= TOL, (p.tolist(), got.tolist(), want.tolist())
        py = ensembles[0].probe(p, "members", tf2, second=ensembles[1])["expected_rgba"]
        np.testing.assert_allclose(py, got, rtol=0, atol=1e-6)
    npy = tmp_path / "cli.npy"
    refcase.run_udvr("render", paths[0], "--model", "members", "--tf2", tmp_path / "tf2.vti",
                     "--second", paths[1], "--size", "12x9", "--float", npy, "-o",
                     tmp_path / "cli.png")
    cli = np.load(npy)
    assert cli[..., 3].max() > 1e-3, "the volume is not in view: the test checks nothing"
    py = udvr.render(ensembles[0], "members", tf2, (12, 9), second=ensembles[1])
    np.testing.assert_allclose(py, cli, rtol=0, atol=1e-6)
    # Python's paths are read as ensembles for both fields, as the CLI reads them
    np.testing.assert_allclose(udvr.render(str(paths[0]), "members", tf2, (12, 9),
                                           second=str(paths[1])), cli, rtol=0, atol=1e-6)
    # members has no value x gradient kernel: --tf2 without --second is refused, and a second
    # input that holds no members says so
    for args, words in [([], "not --tf2 alone"), (["--second", tmp_path / "tf2.vti"], "ensemble")]:
        p = subprocess.run([str(refcase.udvr_binary()), "render", str(paths[0]), "--model",
                            "members", "--tf2", str(tmp_path / "tf2.vti"),
                            *[str(a) for a in args], "-o", str(tmp_path / "x.png")],
                           capture_output=True, text=True)
        assert p.returncode != 0 and words in p.stderr, (args, p.stderr)


# ---- models that read an ensemble's members (the Python API) -------------------------------

MEMBER_KINDS = model_table.names("bivariate", members=True)


@pytest.mark.parametrize("kind", MEMBER_KINDS)
def test_members_matches_reference(tmp_path, kind):
    """Two ensembles (x from the first's members, y from the second's, independent: atoms 1/n₁
    and 1/n₂ at each member's trilinear value) through udvr.Model.probe and udvr.render with a
    TF2 and second=, against reference_bivariate on reference.RefMembers: expected_rgba within
    TOL, the image within TOL_RENDER."""
    rng = np.random.default_rng(77)
    shape, origin, spacing = (3, 5, 4), rng.uniform(-3, 3, 3), rng.uniform(0.5, 2.0, 3)
    ens, refs, ranges = [], [], []
    for n in (5, 4):
        values = (rng.uniform(-1, 2, shape) + rng.uniform(0.05, 0.8, (n, 1, 1, 1))
                  * rng.normal(size=(n,) + shape)).astype(np.float32)
        ens.append(udvr.Ensemble(values, list(origin), list(spacing)))
        refs.append(ref.RefMembers(values, origin, spacing))
        a, b = float(values.min()), float(values.max())
        ranges.append((a + 0.1 * (b - a), b - 0.1 * (b - a)))  # clamping on both sides
    t = r2.random_tf2(rng, ranges[0], ranges[1], 7, 5, zero_frac=0.2)
    t.write_vti(tmp_path / "tf2.vti")
    tf2 = udvr.TransferFunction2D.read(str(tmp_path / "tf2.vti"))
    first = udvr.members_model(ens[0])
    for p in refcase.random_points(rng, [4, 5, 3], 2):
        got = first.probe(point=list(p), model=kind, tf=tf2, second=ens[1])
        want = rb.classify_bivariate(refs[0], refs[1], kind, t, p[None, :])[0]
        diff = np.abs(np.asarray(got["expected_rgba"], float) - want).max()
        assert diff <= TOL, (kind, p.tolist(), got["expected_rgba"], want.tolist(), diff)
    _, cam, ps = refcase.random_camera(rng, refs[0], "perspective")
    camera = udvr.Camera(position=list(cam["position"]), focal_point=list(cam["focal_point"]),
                         view_up=list(cam["view_up"]), view_angle=cam["view_angle"])
    got = np.asarray(udvr.render(ens[0], kind, tf2, size=(12, 9), camera=camera,
                                 second=ens[1]), float)
    want = rb.render_bivariate(refs[0], refs[1], kind, t, 12, 9, cam, parallel_scale=ps)
    assert want[..., 3].max() > 1e-3, "the volume is not in view"
    assert np.abs(got - want).max() <= TOL_RENDER, (kind, np.abs(got - want).max())
