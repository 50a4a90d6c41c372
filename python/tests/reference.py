"""An independent NumPy reference of SPEC §3–§5, written from the SPEC (not from the C++).

It checks `udvr probe --json` and `udvr render --float` on random inputs
(test_reference_probe.py, test_reference_render.py). Everything is float64.

Conventions (SPEC):
- arrays are (Z, Y, X[, components]), x fastest; points are index coordinates (i, j, k) = (x, y, z);
- a TF is piecewise linear between control points, clamped outside, right-continuous at steps
  (two points at the same x: the later one holds from x on);
- classification returns (E[α·r], E[α·g], E[α·b], E[α]).

Integrals of the TF are exact: between the merged control points of colour and opacity, α·c is a
quadratic, so Gauss–Legendre with interior nodes integrates it exactly and never evaluates a step.
The Gaussian expectation is the closed form per quadratic piece (checked against adaptive
quadrature in test_reference_self.py); the uniform sum (box spline) is built by convolving one
scaled uniform at a time, exactly, as piecewise polynomials (Chebyshev interpolation of degree n
on every piece between the shifted breakpoints), so its accuracy does not depend on a grid.
"""
import json
import math

import numpy as np
from numpy.polynomial import chebyshev as C
from scipy.special import ndtr

SQRT3 = math.sqrt(3.0)
ZERO_WIDTH = 1e-12  # × data range: quantile-mean zero-width rule (SPEC §4)

# Every model of the model table (udvr.models(), src/udvr/classify/model_rows.h) that renders with
# a 1D TF, by its CLI name → the distribution of SPEC §3–§4 this module evaluates for it (RefModel
# .classify; "members": RefMembers). A fast form, its alias and its exact form share one
# distribution; the tests hold each to its own tolerance. test_reference_coverage.py fails for a
# row of the table that is neither here nor in NO_REFERENCE: adding a model adds its reference.
MODELS = {
    "mean": "mean", "uniform": "uniform", "uniform-fast": "uniform", "uniform-exact": "uniform",
    "gaussian": "gaussian", "gaussian-exact": "gaussian", "gmm-ordered": "gmm-ordered",
    "quantile-range": "quantile-range", "quantile-mean": "quantile-mean",
    "quantile-mean-mass": "quantile-mean-mass", "iqr": "iqr", "quartile-lower": "quartile-lower",
    "quartile-middle": "quartile-middle", "quartile-upper": "quartile-upper",
    "members": "members", "gmm-mc": "gmm-mc",
}
# Rows of the table with a 1D TF and no reference here, each with why and what checks it instead
# (none today). gmm-mc is rendered, not classified per sample: render_realizations.
NO_REFERENCE = {}

# ----------------------------------------------------------------------------------------------
# Transfer functions
# ----------------------------------------------------------------------------------------------


class TF:
    """A 1D TF: colour points (cx, rgb (n,3)) and opacity points (ox, alpha (m,))."""

    def __init__(self, cx, rgb, ox, alpha):
        self.cx = np.asarray(cx, float)
        self.rgb = np.asarray(rgb, float).reshape(-1, 3)
        self.ox = np.asarray(ox, float)
        self.alpha = np.asarray(alpha, float)
        assert np.all(np.diff(self.cx) >= 0) and np.all(np.diff(self.ox) >= 0)
        # Pieces between consecutive distinct control points (plus the two unbounded ends).
        self.breaks = np.unique(np.concatenate([self.cx, self.ox]))

    def to_paraview(self, name="reference"):
        rgbp = []
        for x, c in zip(self.cx, self.rgb):
            rgbp += [float(x), float(c[0]), float(c[1]), float(c[2])]
        pts = []
        for x, a in zip(self.ox, self.alpha):
            pts += [float(x), float(a), 0.5, 0.0]
        return [{"Name": name, "ColorSpace": "RGB", "RGBPoints": rgbp, "Points": pts}]

    def write(self, path):
        with open(path, "w") as fh:
            json.dump(self.to_paraview(), fh)

    @staticmethod
    def _pwl(xs, fs, x):
        """Piecewise linear, clamped, right-continuous at steps; x any shape, fs (n,) or (n,c)."""
        x = np.asarray(x, float)
        n = len(xs)
        i = np.searchsorted(xs, x, side="right")  # first point with xs[i] > x
        i1 = np.clip(i, 1, n - 1) if n > 1 else np.zeros_like(i)
        i0 = np.maximum(i1 - 1, 0)
        x0, x1 = xs[i0], xs[i1]
        den = np.where(x1 > x0, x1 - x0, 1.0)
        t = np.where(x1 > x0, (x - x0) / den, 0.0)
        f0, f1 = fs[i0], fs[i1]
        if fs.ndim == 2:
            t = t[..., None]
        v = f0 + t * (f1 - f0)
        lo = x < xs[0]
        hi = x >= xs[-1]
        if fs.ndim == 2:
            lo, hi = lo[..., None], hi[..., None]
        v = np.where(lo, fs[0], v)
        v = np.where(hi, fs[-1], v)
        return v

    def __call__(self, x):
        """(α·r, α·g, α·b, α) at x: shape x.shape + (4,)."""
        a = self._pwl(self.ox, self.alpha, x)
        c = self._pwl(self.cx, self.rgb, x)
        return np.concatenate([c * a[..., None], a[..., None]], axis=-1)

    def integral(self, a, b):
        """∫_a^b (α·c, α) dx for arrays a ≤ b (exact): shape a.shape + (4,)."""
        a = np.asarray(a, float)
        b = np.asarray(b, float)
        edges = np.concatenate([[-np.inf], self.breaks, [np.inf]])
        lo = np.maximum(a[..., None], edges[:-1])  # (..., P)
        hi = np.minimum(b[..., None], edges[1:])
        w = np.maximum(hi - lo, 0.0)
        mid = np.where(w > 0, 0.5 * (lo + hi), 0.0)
        mid = np.where(np.isfinite(mid), mid, 0.0)
        h = 0.5 * w / SQRT3  # 2-point Gauss–Legendre nodes mid ± h, exact for cubics
        f = self(mid - h) + self(mid + h)  # (..., P, 4)
        return np.sum(0.5 * w[..., None] * f, axis=-2)

    def interval_mean(self, a, b, zero):
        """Mean of (α·c, α) over [a, b]; widths ≤ zero use TF(b) (SPEC §4)."""
        a = np.asarray(a, float)
        b = np.asarray(b, float)
        w = b - a
        safe = np.where(w > zero, w, 1.0)
        m = self.integral(a, b) / safe[..., None]
        return np.where((w > zero)[..., None], m, self(b))

    def quadratic_pieces(self):
        """Finite pieces [l, r] with (α·c, α) = c0 + c1 (x−m) + c2 (x−m)², m the midpoint."""
        l, r = self.breaks[:-1], self.breaks[1:]
        m = 0.5 * (l + r)
        h = 0.25 * (r - l)
        f0, fm, fp = self(m), self(m - h), self(m + h)
        c0 = f0
        c1 = (fp - fm) / (2 * h)[:, None]
        c2 = (fp - 2 * f0 + fm) / (2 * h * h)[:, None]
        return l, r, m, c0, c1, c2

    def gaussian_expectation(self, mu, sigma, zero=0.0):
        """E[(α·c, α)(X)], X ~ N(mu, sigma²), closed form per quadratic piece; sigma ≤ zero:
        TF(mu)."""
        mu = np.asarray(mu, float)
        sigma = np.asarray(sigma, float)
        ok = sigma > zero
        s = np.where(ok, sigma, 1.0)[..., None]
        m_ = mu[..., None]
        out = np.zeros(mu.shape + (4,))
        # Unbounded ends: constant TF values.
        zl = (self.breaks[0] - m_) / s
        zr = (self.breaks[-1] - m_) / s
        out += ndtr(zl[..., 0])[..., None] * self(np.array(self.breaks[0] - 1.0))
        out += ndtr(-zr[..., 0])[..., None] * self(np.array(self.breaks[-1]))
        if len(self.breaks) > 1:
            l, r, m, c0, c1, c2 = self.quadratic_pieces()  # (P,), (P,4)
            za = (l - m_) / s  # (..., P)
            zb = (r - m_) / s
            # Φ(zb) − Φ(za) without cancellation on either tail.
            mass = np.where(za > 0, ndtr(-za) - ndtr(-zb), ndtr(zb) - ndtr(za))
            pa = np.exp(-0.5 * za * za) / math.sqrt(2 * math.pi)
            pb = np.exp(-0.5 * zb * zb) / math.sqrt(2 * math.pi)
            i1 = pa - pb  # ∫ z φ
            i2 = mass + za * pa - zb * pb  # ∫ z² φ
            d = (m_ - m)[..., None]  # μ − m (..., P, 1)
            sg = s[..., None]
            A = c0 + c1 * d + c2 * d * d  # F = A + B z + Cq z²
            B = (c1 + 2 * c2 * d) * sg
            Cq = c2 * sg * sg
            out += np.sum(A * mass[..., None] + B * i1[..., None] + Cq * i2[..., None], axis=-2)
        return np.where(ok[..., None], out, self(mu))


# ----------------------------------------------------------------------------------------------
# Sum of independent scaled uniforms (the box spline of SPEC §3 `uniform`)
# ----------------------------------------------------------------------------------------------

_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)  # exact for degree ≤ 15


def _cheb_nodes(n):
    k = np.arange(n + 1)
    return np.cos(np.pi * (2 * k + 1) / (2 * (n + 1)))


class _PiecewiseCdf:
    """A CDF on [0, T]: 0 left of 0, 1 right of T, Chebyshev series (in u ∈ [−1,1]) per piece."""

    def __init__(self, edges, coef):
        self.edges = edges  # (P+1,)
        self.coef = coef  # (deg+1, P)
        self.T = edges[-1]

    def _locate(self, x):
        i = np.clip(np.searchsorted(self.edges, x, side="right") - 1, 0, len(self.edges) - 2)
        l, r = self.edges[i], self.edges[i + 1]
        u = np.clip(2 * (x - l) / (r - l) - 1, -1, 1)
        return i, u, r - l

    def __call__(self, x):
        x = np.asarray(x, float)
        i, u, _ = self._locate(x)
        v = C.chebval(u, self.coef[:, i], tensor=False)
        return np.where(x <= 0, 0.0, np.where(x >= self.T, 1.0, v))

    def antiderivative(self):
        """I(x) = ∫_{-∞}^x CDF, as a function."""
        widths = np.diff(self.edges)
        ic = C.chebint(self.coef, lbnd=-1, axis=0) * (0.5 * widths)  # ∫ over the piece from l
        per_piece = C.chebval(np.ones(1), ic, tensor=True)[:, 0]  # value at u=1
        start = np.concatenate([[0.0], np.cumsum(per_piece)])

        def I(x):
            x = np.asarray(x, float)
            i, u, _ = self._locate(x)
            v = start[i] + C.chebval(u, ic[:, i], tensor=False)
            return np.where(x <= 0, 0.0, np.where(x >= self.T, start[-1] + (x - self.T), v))

        return I

    def density_pieces(self):
        widths = np.diff(self.edges)
        return C.chebder(self.coef, axis=0) * (2.0 / widths)


def uniform_sum_cdf(widths):
    """The CDF of Σ widths_c · U_c (U_c ~ U[0,1] independent, widths > 0, descending), exactly
    as Chebyshev pieces, by convolving one scaled uniform at a time."""
    ws = np.asarray(widths, float)
    # First uniform: CDF x / a on [0, a].
    a0 = ws[0]
    cdf = _PiecewiseCdf(np.array([0.0, a0]), np.array([[0.5], [0.5]]))  # (1+u)/2
    deg = 1
    for a in ws[1:]:
        I = cdf.antiderivative()
        T = cdf.T + a
        edges = np.unique(np.concatenate([cdf.edges, cdf.edges + a]))
        edges = edges[np.concatenate([[True], np.diff(edges) > 1e-14 * T])]
        edges[-1] = T
        deg += 1
        u = _cheb_nodes(deg)  # (deg+1,)
        l, r = edges[:-1], edges[1:]
        x = l[None, :] + (r - l)[None, :] * (u[:, None] + 1) / 2  # (deg+1, P)
        vals = (I(x) - I(x - a)) / a  # new CDF at the nodes: (1/a)∫_{x−a}^{x} CDF
        V = C.chebvander(u, deg)  # (deg+1, deg+1)
        coef = np.linalg.solve(V, vals)
        cdf = _PiecewiseCdf(edges, coef)
    return cdf


def uniform_sum_expectation(tf, shift, widths, tiny):
    """E[TF(shift + Σ widths_c · U_c)] with U_c ~ U[0,1] independent; widths ≤ tiny go into the
    shift as their means (their effect is below the SPEC's 1e−4)."""
    widths = np.asarray(widths, float)
    shift = float(shift) + 0.5 * float(np.sum(widths[widths <= tiny]))
    ws = np.sort(widths[widths > tiny])[::-1]
    if len(ws) == 0:
        return tf(np.array(shift))
    cdf = uniform_sum_cdf(ws)
    # E[F(shift + Y)] = ∫_0^T F(shift + y) p(y) dy, split at the CDF's and the TF's breakpoints.
    dens = cdf.density_pieces()
    cuts = np.unique(np.concatenate([cdf.edges, np.clip(tf.breaks - shift, 0, cdf.T)]))
    l, r = cuts[:-1], cuts[1:]
    keep = r > l
    l, r = l[keep], r[keep]
    y = 0.5 * (l + r)[:, None] + 0.5 * (r - l)[:, None] * _GL_X[None, :]  # (P, G)
    i, u, _ = cdf._locate(y.ravel())
    p = C.chebval(u, dens[:, i], tensor=False).reshape(y.shape)
    f = tf(shift + y)  # (P, G, 4)
    return np.sum(0.5 * (r - l)[:, None, None] * _GL_W[None, :, None] * p[..., None] * f,
                  axis=(0, 1))


# ----------------------------------------------------------------------------------------------
# Models (SPEC §2–§4)
# ----------------------------------------------------------------------------------------------


class RefModel:
    """Arrays as written to the .vti (shape (Z,Y,X[,c])) plus geometry."""

    def __init__(self, mean, stddev=None, vmin=None, vmax=None, quantiles=None, iqr=None,
                 gmm=None, origin=(0, 0, 0), spacing=(1, 1, 1), bounds=None,
                 full_res_min_spacing=None, levels=None):
        self.mean = np.asarray(mean, float)
        Z, Y, X = self.mean.shape
        self.dims = np.array([X, Y, Z])
        self.stddev = None if stddev is None else np.asarray(stddev, float)
        self.vmin = self.mean if vmin is None else np.asarray(vmin, float)
        self.vmax = self.mean if vmax is None else np.asarray(vmax, float)
        self.quantiles = None if quantiles is None else np.asarray(quantiles, float)
        # Quantile levels t_0 = 0 … t_q = 1 (SPEC §7 quantile_levels); None: even, j/q.
        self.levels = None if levels is None else np.asarray(levels, float)
        self.iqr = None if iqr is None else np.asarray(iqr, float)
        self.gmm = None if gmm is None else np.asarray(gmm, float)
        self.origin = np.asarray(origin, float)
        self.spacing = np.asarray(spacing, float)
        gb = np.ravel(np.column_stack([self.origin, self.origin + (self.dims - 1) * self.spacing]))
        self.bounds = gb if bounds is None else np.asarray(bounds, float)
        self.full_res_min_spacing = (float(self.spacing.min()) if full_res_min_spacing is None
                                     else float(full_res_min_spacing))

    def quantile_levels(self):
        q = self.quantiles.shape[-1] - 1
        return np.arange(q + 1) / q if self.levels is None else self.levels

    def population(self, kind):
        """(j0, j1, share): the boundaries j0 … j1 a quantile-range-family kind covers (the ones
        at its levels: j/q for even levels) and each of its quantiles' share of their mass."""
        if kind == "iqr":
            return 0, 1, np.ones(1)
        t = self.quantile_levels()
        lo_t, hi_t = {"quantile-range": (0, 1), "quantile-mean": (0, 1),
                      "quantile-mean-mass": (0, 1), "quartile-lower": (0, .25),
                      "quartile-middle": (.25, .75), "quartile-upper": (.75, 1)}[kind]
        j0, j1 = int(np.argmin(abs(t - lo_t))), int(np.argmin(abs(t - hi_t)))
        mass = np.diff(t[j0:j1 + 1])
        return j0, j1, mass / mass.sum()

    def quantile_mean_weights(self, w, kind):
        """Eq. 5's weights p_j for quantile widths w (..., q), normalised over the last axis:
        mass_j / w_j (quantile-mean; widths ≤ the zero-width threshold share the weight by their
        masses) or mass_j (quantile-mean-mass)."""
        mass = np.diff(self.quantile_levels())
        if kind == "quantile-mean-mass":
            pw = np.broadcast_to(mass, w.shape)
        else:
            lo, hi = self.data_range()
            zero = w <= ZERO_WIDTH * (hi - lo)
            anyz = zero.any(axis=-1, keepdims=True)
            pw = np.where(anyz, zero * mass, mass / np.where(zero, 1.0, w))
        return pw / pw.sum(axis=-1, keepdims=True)

    def data_range(self):
        """SPEC §4: [min b_0, max b_q] with quantiles, else [min min, max max]."""
        if self.quantiles is not None:
            return float(self.quantiles[..., 0].min()), float(self.quantiles[..., -1].max())
        return float(self.vmin.min()), float(self.vmax.max())

    # -- reconstruction (SPEC §3) ---------------------------------------------------------------
    def corners(self, p):
        """Trilinear corners of index-space points p (N,3): flat (z,y,x) indices and weights, (N,8).
        Points are clamped into the grid; on the last plane the cell below is used (weight 1)."""
        p = np.clip(np.asarray(p, float), 0, self.dims - 1)
        c0 = np.minimum(np.floor(p).astype(int), np.maximum(self.dims - 2, 0))
        f = p - c0
        idx, wts = [], []
        for dz in (0, 1):
            for dy in (0, 1):
                for dx in (0, 1):
                    i = np.minimum(c0[:, 0] + dx, self.dims[0] - 1)
                    j = np.minimum(c0[:, 1] + dy, self.dims[1] - 1)
                    k = np.minimum(c0[:, 2] + dz, self.dims[2] - 1)
                    w = ((f[:, 0] if dx else 1 - f[:, 0]) * (f[:, 1] if dy else 1 - f[:, 1])
                         * (f[:, 2] if dz else 1 - f[:, 2]))
                    idx.append((k * self.dims[1] + j) * self.dims[0] + i)
                    wts.append(w)
        return np.stack(idx, 1), np.stack(wts, 1)

    def _lerp(self, arr, idx, w):
        flat = arr.reshape(int(np.prod(self.dims)), -1)  # (V, c)
        return np.einsum("nc,nck->nk", w, flat[idx])

    def mean_at(self, p):
        idx, w = self.corners(p)
        return self._lerp(self.mean, idx, w)[:, 0]

    def gaussian_at(self, p):
        idx, w = self.corners(p)
        mu = self._lerp(self.mean, idx, w)[:, 0]
        var = np.einsum("nc,nc->n", w * w, self.stddev.ravel()[idx] ** 2)
        return mu, np.sqrt(var)

    def boundaries_at(self, p, arr="quantiles"):
        idx, w = self.corners(p)
        return self._lerp(self.quantiles if arr == "quantiles" else self.iqr, idx, w)

    # -- classification (SPEC §4) ---------------------------------------------------------------
    def classify(self, model, tf, p, uniform_width="variance"):
        """(N, 4) expected (α·r, α·g, α·b, α) at index-space points p (N, 3)."""
        p = np.atleast_2d(np.asarray(p, float))
        model = MODELS.get(model, model)  # a CLI name → its distribution
        lo, hi = self.data_range()
        R = hi - lo
        if model == "mean":
            return tf(self.mean_at(p))
        if model == "gaussian":
            mu, sg = self.gaussian_at(p)
            return tf.gaussian_expectation(mu, sg, zero=0.0)
        if model == "gmm-ordered":
            idx, w = self.corners(p)
            K = self.gmm.shape[-1] // 3
            par = self._lerp(self.gmm, idx, w)  # (N, 3K)
            pi, mu, sg = par[:, :K], par[:, K:2 * K], par[:, 2 * K:]
            e = tf.gaussian_expectation(mu, sg, zero=0.0)  # (N, K, 4)
            return np.sum(pi[..., None] * e, axis=1) / np.sum(pi, axis=1)[:, None]
        if model == "uniform":
            idx, w = self.corners(p)
            if uniform_width == "minmax":
                l_c, h_c = self.vmin.ravel()[idx], self.vmax.ravel()[idx]
            else:
                m_c, s_c = self.mean.ravel()[idx], self.stddev.ravel()[idx]
                l_c, h_c = m_c - SQRT3 * s_c, m_c + SQRT3 * s_c
            out = []
            for n in range(len(p)):
                keep = w[n] > 0
                shift = np.sum(w[n][keep] * l_c[n][keep])
                widths = w[n][keep] * (h_c[n][keep] - l_c[n][keep])
                out.append(uniform_sum_expectation(tf, shift, widths, tiny=1e-9 * max(R, 1e-30)))
            return np.array(out)
        if model in ("quantile-range", "quartile-lower", "quartile-middle", "quartile-upper",
                     "iqr"):
            if model == "iqr":
                b = self.boundaries_at(p, "iqr")
            else:
                b = self.boundaries_at(p)
            j0, j1, share = self.population(model)
            m = tf.interval_mean(b[:, j0:j1], b[:, j0 + 1:j1 + 1], zero=0.0)  # (N, j1-j0, 4)
            return np.sum(share[None, :, None] * m, axis=1)
        if model in ("quantile-mean", "quantile-mean-mass"):
            b = self.boundaries_at(p)
            mids = 0.5 * (b[:, 1:] + b[:, :-1])
            pw = self.quantile_mean_weights(np.diff(b, axis=1), model)
            return np.sum(pw[..., None] * tf(mids), axis=1)
        raise ValueError("unknown model " + model)


class RefMembers:
    """The ensemble's own expected classification (`members`, issue 12): each member is a mean
    field (RefModel of its values), and a sample's (E[α·c], E[α]) is the average over the members
    of their mean-field classifications at the point (before compositing, not an average of
    images). Geometry as RefModel; members (n, Z, Y, X)."""

    def __init__(self, members, origin=(0, 0, 0), spacing=(1, 1, 1)):
        self.fields = [RefModel(m, origin=origin, spacing=spacing) for m in np.asarray(members)]
        first = self.fields[0]
        self.dims, self.origin, self.spacing = first.dims, first.origin, first.spacing
        self.bounds, self.full_res_min_spacing = first.bounds, first.full_res_min_spacing

    def classify(self, model, tf, p, uniform_width="variance"):
        assert MODELS.get(model) == "members", model
        return np.mean([f.classify("mean", tf, p) for f in self.fields], axis=0)


# ----------------------------------------------------------------------------------------------
# Camera and rendering (SPEC §5)
# ----------------------------------------------------------------------------------------------


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def _rotate(v, axis, deg):
    """Rotate v by deg degrees about the unit axis (right-hand rule), Rodrigues."""
    k = _unit(axis)
    t = math.radians(deg)
    return (v * math.cos(t) + np.cross(k, v) * math.sin(t)
            + k * np.dot(k, v) * (1 - math.cos(t)))


def default_camera(bounds, azimuth=30.0, elevation=20.0, zoom=1.0, view_angle=30.0):
    """bench/peer/vtk_render.py: fit the bounding sphere in the vertical view angle on +z, then
    vtkCamera::Azimuth (about the view-up through the focal point) and Elevation (about
    −(view sideways) = −(forward × up)), then OrthogonalizeViewUp."""
    b = np.asarray(bounds, float)
    c = 0.5 * (b[0::2] + b[1::2])
    radius = 0.5 * np.linalg.norm(b[1::2] - b[0::2])
    dist = radius / math.sin(math.radians(view_angle) / 2) / zoom
    pos = c + np.array([0.0, 0.0, dist])
    up = np.array([0.0, 1.0, 0.0])
    pos = c + _rotate(pos - c, up, azimuth)
    fwd = _unit(c - pos)
    side = _unit(np.cross(fwd, up))  # VTK's first view-transform row: up × (−forward)
    pos = c + _rotate(pos - c, -side, elevation)
    return dict(position=pos, focal_point=c, view_up=up, view_angle=view_angle)


def camera_rays(cam, width, height, parallel_scale=None):
    """Origins and unit directions (H, W, 3) through pixel centres; pixel (0,0) top-left."""
    pos = np.asarray(cam["position"], float)
    fwd = _unit(np.asarray(cam["focal_point"], float) - pos)
    right = _unit(np.cross(fwd, cam["view_up"]))
    up = np.cross(right, fwd)  # orthogonalised view-up
    aspect = width / height
    nx = 2 * (np.arange(width) + 0.5) / width - 1  # −1 left … +1 right
    ny = 1 - 2 * (np.arange(height) + 0.5) / height  # +1 top … −1 bottom
    NX, NY = np.meshgrid(nx, ny)  # (H, W)
    if parallel_scale is not None:
        s = parallel_scale
        # ndc · aspect · scale: in this order a pixel centre that lies on a box face in exact
        # arithmetic (axis-aligned orthographic views) stays on it in floating point too.
        orig = pos + (NX * aspect * s)[..., None] * right + (NY * s)[..., None] * up
        d = np.broadcast_to(fwd, orig.shape)
    else:
        t = math.tan(math.radians(cam["view_angle"]) / 2)
        d = fwd + (NX * aspect * t)[..., None] * right + (NY * t)[..., None] * up
        d = d / np.linalg.norm(d, axis=-1, keepdims=True)
        orig = np.broadcast_to(pos, d.shape)
    return np.array(orig), np.array(d)


def box_hits(bounds, orig, d):
    """Slab test: t_entry (clamped to ≥ 0), t_exit and a hit mask; distances along unit d."""
    b = np.asarray(bounds, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        t1 = (b[0::2] - orig) * inv
        t2 = (b[1::2] - orig) * inv
    tmin = np.where(np.isnan(t1), -np.inf, np.minimum(t1, t2))
    tmax = np.where(np.isnan(t1), np.inf, np.maximum(t1, t2))
    # Parallel to a slab: inside (both t ±inf with the right sign) or outside (nan handled above).
    par = d == 0
    inside = (orig >= b[0::2]) & (orig <= b[1::2])
    tmin = np.where(par, np.where(inside, -np.inf, np.inf), tmin)
    tmax = np.where(par, np.where(inside, np.inf, -np.inf), tmax)
    t0 = np.maximum(tmin.max(axis=-1), 0.0)
    t1_ = tmax.min(axis=-1)
    return t0, t1_, t1_ >= t0


def render(model, kind, tf, width, height, cam, parallel_scale=None, step=None, unit=None,
           early_exit=0.99, background=(1.0, 1.0, 1.0)):
    """SPEC §5 front-to-back ray casting: (H, W, 4) float64 RGBA, RGB with the background
    composited, A the accumulated opacity before the background."""
    step = 0.5 * model.full_res_min_spacing if step is None else step
    unit = model.full_res_min_spacing if unit is None else unit
    orig, d = camera_rays(cam, width, height, parallel_scale)
    t0, t1, hit = box_hits(model.bounds, orig, d)
    length = np.where(hit, t1 - t0, -1.0)
    # Samples s = 0.. while (s + ½)Δ ≤ length.
    ns = np.maximum(np.where(hit, np.floor(length / step + 0.5), 0), 0).astype(int)
    smax = int(ns.max()) if ns.size else 0
    H, W = hit.shape
    s = np.arange(smax)
    t = np.where(hit, t0, 0.0)[..., None] + (s + 0.5) * step  # (H, W, S)
    valid = s[None, None, :] < ns[..., None]
    pts = orig[..., None, :] + t[..., None] * d[..., None, :]  # world (H, W, S, 3)
    idx = (pts - model.origin) / model.spacing
    rgba = np.zeros((H, W, smax, 4))
    if valid.any():
        rgba[valid] = model.classify(kind, tf, idx[valid])
    ea = rgba[..., 3]
    alpha = 1.0 - np.power(np.clip(1.0 - ea, 0.0, 1.0), step / unit)
    scale = np.where(ea > 0, alpha / np.where(ea > 0, ea, 1.0), 0.0)
    col = rgba[..., :3] * scale[..., None]
    acc_c = np.zeros((H, W, 3))
    acc_a = np.zeros((H, W))
    alive = np.ones((H, W), bool)
    for k in range(smax):
        use = alive & valid[..., k] & (ea[..., k] > 0)
        tr = 1.0 - acc_a
        acc_c = np.where(use[..., None], acc_c + tr[..., None] * col[..., k, :], acc_c)
        acc_a = np.where(use, acc_a + tr * alpha[..., k], acc_a)
        alive &= ~(use & (acc_a > early_exit))
    out = np.zeros((H, W, 4))
    out[..., :3] = acc_c + (1.0 - acc_a)[..., None] * np.asarray(background, float)
    out[..., 3] = acc_a
    return out


def gmm_realization(model, rng):
    """One gmm-mc realization (SPEC §3): every voxel independently from its own mixture, component
    k with probability max(π_k, 0) / Σ max(π, 0), then N(μ_k, σ_k²); a mean-only RefModel with
    the model's geometry."""
    K = model.gmm.shape[-1] // 3
    g = model.gmm.reshape(-1, 3 * K)
    pi = np.maximum(g[:, :K], 0.0)
    u = rng.random(len(g)) * pi.sum(axis=1)
    pick = np.minimum(np.sum(np.cumsum(pi, axis=1) <= u[:, None], axis=1), K - 1)
    rows = np.arange(len(g))
    values = g[rows, K + pick] + np.maximum(g[rows, 2 * K + pick], 0.0) * rng.standard_normal(
        len(g))
    return RefModel(values.reshape(model.mean.shape), origin=model.origin, spacing=model.spacing,
                    bounds=model.bounds, full_res_min_spacing=model.full_res_min_spacing)


def render_realizations(model, tf, width, height, cam, count, rng, **kw):
    """gmm-mc (SPEC §5): the screen-space average of `count` realizations' mean-field images
    (gmm_realization, render), and the per-pixel standard deviation of one realization's image
    (for the Monte Carlo error of an average). Keyword arguments as render."""
    images = np.array([render(gmm_realization(model, rng), "mean", tf, width, height, cam, **kw)
                       for _ in range(count)])
    return images.mean(axis=0), images.std(axis=0, ddof=1)
