"""reference2d.py (SPEC §9) against still more direct computations, so that a disagreement with
udvr points at udvr: analytic gradients, direct trilinear evaluation, dense numeric integration,
a second quadrature, the other conditioning order, Monte Carlo over whole voxel fields (each
voxel drawn, the field interpolated and differentiated as SPEC §3/§9 say), and reference.py's 1D
classification (a TF2 constant in y)."""
import math

import numpy as np
import pytest

import reference as ref
import reference2d as r2
import refcase


def random_refmodel(seed, dims):
    rng = np.random.default_rng(seed)
    a = refcase.random_model_arrays(rng, dims)
    m = ref.RefModel(a["mean"], stddev=a["stddev"], vmin=a["min"], vmax=a["max"],
                     quantiles=a["quantiles"], iqr=a["iqr"], gmm=a["gmm"],
                     origin=rng.uniform(-3, 3, 3), spacing=rng.uniform(0.5, 2.0, 3))
    return rng, m


def random_points(rng, dims, n):
    """Interior points plus a face, an edge, a corner and a grid point."""
    hi = np.asarray(dims, float) - 1
    pts = list(rng.uniform(0, 1, (n, 3)) * hi)
    face = rng.uniform(0, 1, 3) * hi
    face[rng.integers(3)] = 0.0
    edge = rng.uniform(0, 1, 3) * hi
    edge[0], edge[2] = hi[0], 0.0
    pts += [face, edge, hi * rng.integers(0, 2, 3),
            np.array([rng.integers(0, d) for d in dims], float)]
    return np.array(pts)


def tf2_for(rng, m, W=7, H=5):
    lo, hi = m.data_range()
    return r2.random_tf2(rng, (lo, hi), (0.0, 1.2 * r2.gradient_magnitude_range(m)), W, H)


# ---- gradients ------------------------------------------------------------------------------

@pytest.mark.parametrize("dims", [(5, 4, 3), (2, 3, 1), (1, 4, 2), (6, 1, 1)])
def test_gradients_of_a_linear_field_are_exact(dims):
    rng = np.random.default_rng(sum(dims))
    sp = rng.uniform(0.3, 3.0, 3)
    org = rng.uniform(-2, 2, 3)
    c = rng.normal(size=4)
    X, Y, Z = dims
    k, j, i = np.meshgrid(np.arange(Z), np.arange(Y), np.arange(X), indexing="ij")
    wx, wy, wz = org[0] + i * sp[0], org[1] + j * sp[1], org[2] + k * sp[2]
    f = c[0] + c[1] * wx + c[2] * wy + c[3] * wz
    g = r2.grid_gradients(f, sp)
    want = np.where(np.array(dims) > 1, c[1:], 0.0)
    np.testing.assert_allclose(g, np.broadcast_to(want, g.shape), rtol=1e-12, atol=1e-12)


def test_gradients_of_a_quadratic_against_the_analytic_differences():
    """Central differences are exact for quadratics; one-sided ones at the ends are f' ± h f''/2."""
    dims = (6, 5, 4)
    sp = np.array([0.7, 1.3, 0.4])
    a, b, c, d, e = 0.8, -1.1, 0.5, 2.0, 0.3
    X, Y, Z = dims
    k, j, i = np.meshgrid(np.arange(Z), np.arange(Y), np.arange(X), indexing="ij")
    x, y, z = i * sp[0] + 0.2, j * sp[1] - 0.4, k * sp[2] + 1.0
    f = a * x * x + b * x * y + c * y * y + d * z * z + e * y * z
    g = r2.grid_gradients(f, sp)

    def ends(idx, n, h, f2):  # correction at the first/last point of an axis
        return np.where(idx == 0, 0.5 * h * f2, np.where(idx == n - 1, -0.5 * h * f2, 0.0))

    gx = 2 * a * x + b * y + ends(i, X, sp[0], 2 * a)
    gy = b * x + 2 * c * y + e * z + ends(j, Y, sp[1], 2 * c)
    gz = 2 * d * z + e * y + ends(k, Z, sp[2], 2 * d)
    np.testing.assert_allclose(g, np.stack([gx, gy, gz], -1), rtol=0, atol=1e-12)


@pytest.mark.parametrize("dims", [(4, 3, 5), (2, 3, 2), (3, 1, 4), (5, 4, 6)])
def test_the_32_voxel_form_against_direct_evaluation(dims):
    rng, m = random_refmodel(3 + dims[0], list(dims))
    p = random_points(rng, dims, 20)
    p = np.concatenate([p, p + rng.normal(0, 3, p.shape)])  # and points outside (clamped)
    idx, coef = r2.linear_form(m, p)
    nz = np.any(coef != 0, axis=2).sum(1)
    assert nz.max() <= 32
    for row, c in zip(idx, coef):  # each voxel once per row (padding aside)
        used = row[np.any(c != 0, 1)]
        assert len(np.unique(used)) == len(used)
    np.testing.assert_allclose(coef[..., 0].sum(1), 1.0, atol=1e-14)
    fields = [m.mean, m.quantiles[..., 2], m.iqr[..., 1], rng.normal(size=m.mean.shape)]
    for f in fields:
        Y = np.einsum("nmc,nm->nc", coef[..., 1:], f.ravel()[idx])
        X = np.einsum("nm,nm->n", coef[..., 0], f.ravel()[idx])
        np.testing.assert_allclose(Y, r2.gradient_at(m, f, p), rtol=0, atol=1e-12)
        idx8, w8 = m.corners(p)
        np.testing.assert_allclose(X, np.sum(w8 * f.ravel()[idx8], 1), rtol=0, atol=1e-12)


def test_grid_points_in_the_interior_see_only_their_stencil():
    """At an interior grid point the form is the 7-point gradient stencil and weight 1."""
    _, m = random_refmodel(5, [5, 4, 6])
    idx, coef = r2.linear_form(m, np.array([[2.0, 1.0, 3.0]]))
    keep = np.any(coef[0] != 0, 1)
    assert np.count_nonzero(keep) == 7
    centre = (3 * 4 + 1) * 5 + 2
    np.testing.assert_allclose(coef[0][idx[0] == centre][0], [1, 0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(coef[0][idx[0] == centre + 1][0],
                               [0, 0.5 / m.spacing[0], 0, 0], atol=1e-15)


# ---- TF2 raster -----------------------------------------------------------------------------

def test_tf2_bilinear_at_points_between_and_clamped():
    rng = np.random.default_rng(7)
    t = r2.random_tf2(rng, (-1.0, 2.0), (0.5, 3.0), 4, 3)
    X, Y = np.meshgrid(t.xs, t.ys)
    np.testing.assert_allclose(t.straight(X, Y), t.rgba, atol=1e-14)
    # midpoint of cell (1, 0): the average of its four corners, each of colour and α
    s = t.straight(0.5 * (t.xs[1] + t.xs[2]), 0.5 * (t.ys[0] + t.ys[1]))
    np.testing.assert_allclose(s, t.rgba[0:2, 1:3].mean(axis=(0, 1)), atol=1e-14)
    v = t(0.5 * (t.xs[1] + t.xs[2]), 0.5 * (t.ys[0] + t.ys[1]))
    np.testing.assert_allclose(v, np.concatenate([s[:3] * s[3], [s[3]]]), atol=1e-14)
    np.testing.assert_allclose(t(-50.0, 99.0), t(t.xs[0], t.ys[-1]), atol=1e-14)
    np.testing.assert_allclose(t(t.xs[2] + 0.1, -7.0), t(t.xs[2] + 0.1, t.ys[0]), atol=1e-14)


@pytest.mark.parametrize("binary", [False, True])
def test_tf2_vti_round_trip_and_layout(tmp_path, binary):
    import xml.etree.ElementTree as ET
    rng = np.random.default_rng(8)
    t = r2.random_tf2(rng, (-1.5, 2.25), (0.0, 4.5), 7, 5)
    t.write_vti(tmp_path / "t.vti", binary=binary)
    root = ET.parse(str(tmp_path / "t.vti")).getroot()
    assert root.get("type") == "ImageData"
    img = root.find("ImageData")
    assert img.get("WholeExtent").split() == ["0", "6", "0", "4", "0", "0"]
    np.testing.assert_allclose([float(v) for v in img.get("Origin").split()], [-1.5, 0.0, 0])
    np.testing.assert_allclose([float(v) for v in img.get("Spacing").split()],
                               [3.75 / 6, 4.5 / 4, 1])
    pd = img.find("Piece/PointData")
    assert pd.get("Scalars") == "rgba"
    da = pd.find("DataArray")
    assert (da.get("Name"), da.get("type"), da.get("NumberOfComponents")) == (
        "rgba", "Float32", "4")
    back = r2.TF2.read_vti(tmp_path / "t.vti")
    np.testing.assert_array_equal(back.rgba, t.rgba)  # float32-exact values
    np.testing.assert_allclose(back.domain, t.domain, rtol=1e-15)
    t.write_npy(tmp_path / "t.npy")
    a = np.load(tmp_path / "t.npy")
    assert a.shape == (5, 7, 4) and a.dtype == np.float32
    np.testing.assert_array_equal(a.astype(float), t.rgba)


def dense_segment_mean(t, P0, P1, n=400_001):
    """Trapezoid rule on n points: error O(h²) even across kinks (h = 2.5e−6)."""
    s = np.linspace(0.0, 1.0, n)
    f = t(P0[0] + s * (P1[0] - P0[0]), P0[1] + s * (P1[1] - P0[1]))
    w = np.full(n, 1.0 / (n - 1))
    w[0] = w[-1] = 0.5 / (n - 1)
    return w @ f


def test_mean_along_segment_against_dense_integration():
    rng = np.random.default_rng(9)
    t = r2.random_tf2(rng, (0.0, 3.0), (-1.0, 1.0), 7, 5)
    segs = [((0.1, -0.9), (2.9, 0.8)),  # across many cells
            ((-1.0, -2.0), (4.0, 2.5)),  # starts and ends outside: clamping
            ((0.5, t.ys[2]), (2.7, t.ys[2])),  # along a raster line
            ((t.xs[3], -0.8), (t.xs[3], 3.0)),  # vertical along a column, leaving the top
            ((2.0, 0.3), (0.2, -0.5)),  # reversed direction
            ((1.0, 1.7), (1.0 + 1e-9, 1.9)),  # nearly vertical, above the domain
            ((-3.0, 0.2), (-2.0, 0.6)),  # left of the domain
            ]
    for P0, P1 in segs:
        P0, P1 = np.array(P0), np.array(P1)
        np.testing.assert_allclose(r2.mean_along_segment(t, P0, P1),
                                   dense_segment_mean(t, P0, P1), rtol=0, atol=1e-9,
                                   err_msg=str((P0, P1)))
    P = np.array([1.234, 0.1])
    np.testing.assert_allclose(r2.mean_along_segment(t, P, P), t(*P), atol=1e-15)
    # Vectorised form agrees with one-by-one.
    A = rng.uniform(-1, 4, (6, 3, 2))
    B = rng.uniform(-1, 4, (6, 3, 2))
    v = r2.mean_along_segment(t, A, B)
    assert v.shape == (6, 3, 4)
    np.testing.assert_allclose(v[2, 1], r2.mean_along_segment(t, A[2, 1], B[2, 1]), atol=1e-15)


# ---- bivariate normal -----------------------------------------------------------------------

def dense_gauss(t, m, C, L=9.0, ngl=10):
    """Tensor Gauss–Legendre over rectangles no wider than ½ of the conditional standard
    deviations, split at every raster line: a second, independent quadrature."""
    sx, sy = math.sqrt(C[0][0]), math.sqrt(C[1][1])
    rho = C[0][1] / (sx * sy)
    gx, gw = np.polynomial.legendre.leggauss(ngl)

    def axis(mu, s, lines):
        c = s * math.sqrt(1 - rho * rho)
        n = int(math.ceil(2 * L * s / (0.5 * c)))
        cuts = np.linspace(mu - L * s, mu + L * s, n + 1)
        cuts = np.unique(np.concatenate([cuts, lines[(lines > cuts[0]) & (lines < cuts[-1])]]))
        lo, hi = cuts[:-1], cuts[1:]
        x = (0.5 * (lo + hi))[:, None] + (0.5 * (hi - lo))[:, None] * gx
        w = (0.5 * (hi - lo))[:, None] * gw
        return x.ravel(), w.ravel()

    x, wx = axis(m[0], sx, t.xs)
    y, wy = axis(m[1], sy, t.ys)
    Ci = np.linalg.inv(np.asarray(C, float))
    X, Y = np.meshgrid(x, y, indexing="ij")
    dx, dy = X - m[0], Y - m[1]
    pdf = np.exp(-0.5 * (Ci[0, 0] * dx * dx + 2 * Ci[0, 1] * dx * dy + Ci[1, 1] * dy * dy))
    pdf /= 2 * math.pi * math.sqrt(np.linalg.det(np.asarray(C, float)))
    return np.einsum("i,j,ij,ijc->c", wx, wy, pdf, t(X, Y))


def cov(sx, sy, rho):
    return [[sx * sx, rho * sx * sy], [rho * sx * sy, sy * sy]]


GAUSS_CASES = [  # (mean, sx, sy, rho) over the raster [0, 3] × [−1, 1] of 7 × 5 points
    ((1.3, 0.2), 0.4, 0.3, 0.0),
    ((1.3, 0.2), 0.4, 0.3, 0.7),
    ((2.1, -0.4), 0.05, 0.6, -0.6),  # narrow in x, wide in y
    ((0.9, 0.5), 1.5, 0.02, 0.3),  # wide in x (beyond the domain), narrow in y
    ((-0.5, 1.3), 0.8, 0.5, 0.8),  # mean outside the domain
    ((1.0, 0.0), 0.01, 0.01, 0.5),  # inside one cell
    ((1.6, 0.1), 3.0, 2.0, -0.4),  # much wider than the domain
]


@pytest.mark.parametrize("case", range(len(GAUSS_CASES)))
def test_gaussian_against_a_dense_second_quadrature(case):
    rng = np.random.default_rng(10)
    t = r2.random_tf2(rng, (0.0, 3.0), (-1.0, 1.0), 7, 5)
    m, sx, sy, rho = GAUSS_CASES[case]
    C = cov(sx, sy, rho)
    got = r2.gaussian_expectation2d(t, m[0], m[1], C[0][0], C[0][1], C[1][1])[0]
    np.testing.assert_allclose(got, dense_gauss(t, m, C), rtol=0, atol=1e-9)
    for orient in ("x", "y"):  # both conditioning orders
        alt = r2.gaussian_expectation2d(t, m[0], m[1], C[0][0], C[0][1], C[1][1], orient=orient)
        np.testing.assert_allclose(alt[0], got, rtol=0, atol=1e-9)


def line_gauss(t, m, v, L=10.0):
    """E[TF2(m + v Z)], Z ~ N(0,1): split at every raster line crossed, GL-16 per piece."""
    gx, gw = np.polynomial.legendre.leggauss(16)
    cuts = [np.arange(-L, L + 1e-9, 0.25)]
    for c, lines in ((0, t.xs), (1, t.ys)):
        if v[c] != 0:
            z = (lines - m[c]) / v[c]
            cuts.append(z[np.abs(z) < L])
    cuts = np.unique(np.concatenate(cuts))
    lo, hi = cuts[:-1], cuts[1:]
    z = (0.5 * (lo + hi))[:, None] + (0.5 * (hi - lo))[:, None] * gx
    w = (0.5 * (hi - lo))[:, None] * gw * np.exp(-0.5 * z * z) / math.sqrt(2 * math.pi)
    return np.einsum("ig,igc->c", w, t(m[0] + v[0] * z, m[1] + v[1] * z))


@pytest.mark.parametrize("rho", [0.95, -0.999, 0.999999, 1.0, -1.0])
def test_gaussian_strong_correlation_both_orders_and_rank_one(rho):
    rng = np.random.default_rng(11)
    t = r2.random_tf2(rng, (0.0, 3.0), (-1.0, 1.0), 7, 5)
    m, sx, sy = (1.4, 0.1), 0.7, 0.5
    C = cov(sx, sy, rho)
    got = [r2.gaussian_expectation2d(t, m[0], m[1], C[0][0], C[0][1], C[1][1], orient=o)[0]
           for o in (None, "x", "y")]
    np.testing.assert_allclose(got[1], got[0], atol=1e-9)
    np.testing.assert_allclose(got[2], got[0], atol=1e-9)
    if abs(rho) == 1.0:  # exactly a line: a 1D integral
        np.testing.assert_allclose(got[0], line_gauss(t, m, (sx, rho * sy)), atol=1e-9)


def test_gaussian_degenerate_axes():
    rng = np.random.default_rng(12)
    t = r2.random_tf2(rng, (0.0, 3.0), (-1.0, 1.0), 7, 5)
    # σ_x = 0: X fixed, G normal; σ_y = 0: the other way; both 0: TF2 at the mean.
    np.testing.assert_allclose(r2.gaussian_expectation2d(t, 1.1, 0.2, 0.0, 0.0, 0.09)[0],
                               line_gauss(t, (1.1, 0.2), (0.0, 0.3)), atol=1e-10)
    np.testing.assert_allclose(r2.gaussian_expectation2d(t, 1.1, 0.2, 0.25, 0.0, 0.0)[0],
                               line_gauss(t, (1.1, 0.2), (0.5, 0.0)), atol=1e-10)
    np.testing.assert_allclose(r2.gaussian_expectation2d(t, 1.1, 0.2, 0.0, 0.0, 0.0)[0],
                               t(1.1, 0.2), atol=1e-15)


def test_inner_closed_form_against_the_1d_gaussian_of_reference():
    """Along y at fixed x the TF2 is a 1D TF (control points at the rows): reference.py's closed
    form gives the same expectation."""
    rng = np.random.default_rng(13)
    t = r2.random_tf2(rng, (0.0, 3.0), (-1.0, 1.0), 7, 5)
    for a, mb, s in [(0.3, 0.1, 0.2), (2.2, -1.4, 0.05), (t.xs[2], 0.9, 3.0), (-1.0, 0.0, 1e-7)]:
        col = t.straight(np.full(t.H, a), t.ys)
        tf1 = ref.TF(t.ys, col[:, :3], t.ys, col[:, 3])
        np.testing.assert_allclose(r2.inner_normal(t, a, mb, s),
                                   tf1.gaussian_expectation(np.array(mb), np.array(s)),
                                   atol=1e-13)


# ---- Monte Carlo over whole voxel fields ----------------------------------------------------

N_MC = 1_000_000
MC_TOL = 2e-3


def mc_fields(m, p, draw, n=N_MC, chunk=250_000, seed=0):
    """(X, G) at p for n draws of the whole voxel field: draw(rng, k) → (k, Z, Y, X) fields.
    X is the trilinear interpolation of the drawn field at p and G = n̂·(trilinear blend of the
    drawn field's grid gradients), n̂ from the mean field's gradient there. Both are linear in
    the field, so this direct path (reference.RefModel.corners, grid_gradients) is applied once
    to every unit-impulse field, and each draw is then one dot product."""
    rng = np.random.default_rng(seed)
    idx, w = m.corners(p[None, :])
    mu_y = r2.gradient_at(m, m.mean, p[None, :])[0]
    nh = mu_y / np.linalg.norm(mu_y) if np.linalg.norm(mu_y) > 0 else np.array([1.0, 0, 0])
    V = m.mean.size
    unit = np.eye(V).reshape((V,) + m.mean.shape)  # every voxel's impulse field
    lx = unit.reshape(V, -1)[:, idx[0]] @ w[0]
    g = r2.grid_gradients(unit, m.spacing).reshape(V, -1, 3)
    lg = np.einsum("vkc,k,c->v", g[:, idx[0]], w[0], nh)
    Xs, Gs = [], []
    for k in range(0, n, chunk):
        f = draw(rng, min(chunk, n - k)).reshape(-1, V)
        Xs.append(f @ lx)
        Gs.append(f @ lg)
    return np.concatenate(Xs), np.concatenate(Gs)


def tf2_around(rng, x, g, W=7, H=5):
    """A random raster whose cells are the scale of the spread of (x, g), so that the
    expectation depends on the joint distribution (a TF2 much wider than it would hardly see
    the covariance), reaching a little beyond it on every side (clamping)."""
    (xa, xb), (ga, gb) = np.percentile(x, [1, 99]), np.percentile(g, [1, 99])
    return r2.random_tf2(rng, (xa + 0.1 * (xb - xa), xb - 0.1 * (xb - xa)),
                         (ga + 0.1 * (gb - ga), gb - 0.1 * (gb - ga)), W, H, zero_frac=0.1)


def test_gaussian_against_monte_carlo_of_independent_voxels():
    rng, m = random_refmodel(14, [4, 3, 3])
    for p in [np.array([1.3, 0.6, 1.2]), np.array([3.0, 2.0, 0.4]), np.array([2.0, 1.0, 1.0])]:
        def draw(g, k):
            return m.mean + m.stddev * g.standard_normal((k,) + m.mean.shape)
        X, G = mc_fields(m, p, draw)
        t = tf2_around(rng, X, G)
        want = t(X, G).mean(0)
        got = r2.classify2d(m, "gaussian", t, p[None, :])[0]
        assert np.abs(got - want).max() <= MC_TOL, (p, got, want)
        s = r2.Sample2D(m, p[None, :])
        gm, gs = s.gradient_magnitude("gaussian")
        np.testing.assert_allclose([gm[0], gs[0]], [G.mean(), G.std()], rtol=5e-3,
                                   atol=5e-3 * G.std())
        _, _, vxx, vxg, _ = s.gaussian()
        np.testing.assert_allclose(vxx[0], X.var(), rtol=1e-2)
        np.testing.assert_allclose(vxg[0], np.mean((X - X.mean()) * (G - G.mean())),
                                   atol=1e-2 * math.sqrt(X.var() * G.var()))


def rank_draws(B, levels_t):
    """Voxel fields at ranks t: F_i⁻¹(t) piecewise linear through (j/q, b_{j,i}); B (Z,Y,X,q+1)."""
    q = B.shape[-1] - 1
    s = np.clip(levels_t * q, 0, q)
    j = np.minimum(np.floor(s).astype(int), q - 1)
    f = (s - j)[:, None, None, None]
    Bt = np.moveaxis(B, -1, 0)
    return Bt[j] + f * (Bt[j + 1] - Bt[j])


@pytest.mark.parametrize("seed", [15, 16])
def test_quantile_models_against_monte_carlo_of_the_rank_coupling(seed):
    rng, m = random_refmodel(seed, [4, 3, 3])
    q = m.quantiles.shape[-1] - 1
    lo, hi = m.data_range()
    for p in [rng.uniform(0, 1, 3) * [3, 2, 2], np.array([0.0, 2.0, 1.5])]:
        s = r2.Sample2D(m, p[None, :])
        Xv, Gv = s.polyline()  # only to size the raster to the polyline
        t = tf2_around(rng, Xv[0], Gv[0])
        # quantile-range and the quartile views: t uniform over the rank range.
        for kind, (t0, t1) in [("quantile-range", (0, 1)), ("quartile-middle", (0.25, 0.75)),
                               ("quartile-upper", (0.75, 1.0))]:
            X, G = mc_fields(m, p, lambda g, k: rank_draws(m.quantiles, g.uniform(t0, t1, k)))
            got = s.classify(kind, t)[0]
            want = t(X, G).mean(0)
            assert np.abs(got - want).max() <= MC_TOL, (kind, p, got, want)
            gm, gs = s.gradient_magnitude(kind)
            np.testing.assert_allclose([gm[0], gs[0]], [G.mean(), G.std()], rtol=0,
                                       atol=5e-3 * (abs(G).mean() + 1e-12))
        # iqr: the middle 50 % between the iqr array's two boundaries.
        X, G = mc_fields(m, p, lambda g, k: rank_draws(m.iqr, g.uniform(0, 1, k)))
        got = s.classify("iqr", t)[0]
        assert np.abs(got - t(X, G).mean(0)).max() <= MC_TOL, ("iqr", p)
        # quantile-mean(-mass): draw a quantile j with Eq. 5's probability p_j (from the X-widths
        # of the fields at ranks j/q), evaluate TF2 at its mid-rank field.
        Xb, _ = mc_fields(m, p, lambda g, k: rank_draws(m.quantiles, np.arange(q + 1) / q),
                          n=q + 1, chunk=q + 1)
        w = np.diff(Xb)
        for kind in ("quantile-mean", "quantile-mean-mass"):
            if kind == "quantile-mean-mass":
                pj = np.full(q, 1.0 / q)
            else:
                zero = w <= ref.ZERO_WIDTH * (hi - lo)
                pj = zero.astype(float) if zero.any() else 1.0 / w
                pj = pj / pj.sum()

            def draw(g, k):
                return rank_draws(m.quantiles, (g.choice(q, k, p=pj) + 0.5) / q)

            X, G = mc_fields(m, p, draw)
            want = t(X, G).mean(0)
            got = s.classify(kind, t)[0]
            assert np.abs(got - want).max() <= MC_TOL, (kind, p, got, want)


# ---- a TF2 constant in y is the 1D TF (SPEC §9) -----------------------------------------------

@pytest.mark.parametrize("seed", [17, 18, 19])
def test_constant_in_y_gives_the_1d_classification(seed):
    rng, m = random_refmodel(seed, [5, 4, 3])
    lo, hi = m.data_range()
    R = hi - lo
    W = 9
    alpha = rng.uniform(0, 1, W) * (rng.random(W) > 0.2)
    t2, tf1 = r2.TF2.from_1d(rng.uniform(0, 1, (W, 3)), alpha, lo + 0.1 * R, hi - 0.15 * R,
                             -5.0, 40.0, H=3)
    p = random_points(rng, [5, 4, 3], 12)
    for kind in r2.KINDS:
        got = r2.classify2d(m, kind, t2, p)
        want = m.classify(kind, tf1, p)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12, err_msg=kind)


def test_constant_in_x_gaussian_is_the_1d_gaussian_of_g():
    """A TF2 depending on y only: E over G ~ N(n̂·μ_Y, Σ u_i² σ_i²) alone (1D closed form)."""
    rng, m = random_refmodel(20, [4, 5, 3])
    ys = np.linspace(0.0, 1.2 * r2.gradient_magnitude_range(m), 6)
    rgb, al = rng.uniform(0, 1, (6, 3)), rng.uniform(0, 1, 6)
    row = np.concatenate([rgb, al[:, None]], 1)
    t2 = r2.TF2(np.broadcast_to(row[:, None, :], (6, 3, 4)), (-1.0, 1.0, ys[0], ys[-1]))
    tf1 = ref.TF(ys, rgb, ys, al)
    p = random_points(rng, [4, 5, 3], 6)
    s = r2.Sample2D(m, p)
    _, mg, _, _, vgg = s.gaussian()
    np.testing.assert_allclose(s.classify("gaussian", t2),
                               tf1.gaussian_expectation(mg, np.sqrt(vgg)), atol=1e-12)


def test_mean_model_and_zero_gradient_direction():
    """mean: TF2(x̄, |μ_Y|); where μ_Y = 0, n̂ = +x (quantile G is then d/dx of the boundary
    fields)."""
    rng, m = random_refmodel(21, [4, 3, 3])
    t = tf2_for(rng, m)
    p = random_points(rng, [4, 3, 3], 5)
    s = r2.Sample2D(m, p)
    gnorm = np.linalg.norm(r2.gradient_at(m, m.mean, p), axis=1)
    np.testing.assert_allclose(s.classify("mean", t), t(m.mean_at(p), gnorm), atol=1e-14)
    flat = ref.RefModel(np.full(m.mean.shape, 2.0), stddev=m.stddev, quantiles=m.quantiles,
                        iqr=m.iqr, origin=m.origin, spacing=m.spacing)
    s = r2.Sample2D(flat, p)
    np.testing.assert_array_equal(s.nhat, np.tile([1.0, 0, 0], (len(p), 1)))
    Xv, Gv = s.polyline()
    gx = np.stack([r2.gradient_at(flat, flat.quantiles[..., j], p)[:, 0]
                   for j in range(Xv.shape[1])], 1)
    np.testing.assert_allclose(Gv, gx, atol=1e-12)
    gm, gs = s.gradient_magnitude("mean")
    np.testing.assert_array_equal(gm, 0.0)


# ---- rendering --------------------------------------------------------------------------------

def test_render2d_with_a_constant_in_y_tf2_is_the_1d_render():
    rng, m = random_refmodel(22, [5, 4, 6])
    lo, hi = m.data_range()
    t2, tf1 = r2.TF2.from_1d(rng.uniform(0, 1, (8, 3)), rng.uniform(0, 1, 8), lo, hi, 0.0, 9.0)
    cam = ref.default_camera(m.bounds, 40.0, 25.0, 1.2)
    for kind in ("mean", "quantile-range", "quantile-mean", "gaussian"):
        got = r2.render2d(m, kind, t2, 6, 5, cam)
        want = ref.render(m, kind, tf1, 6, 5, cam)
        assert want[..., 3].max() > 1e-3
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12, err_msg=kind)
