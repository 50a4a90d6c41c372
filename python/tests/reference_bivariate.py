"""An independent NumPy reference of SPEC §9's bivariate fields (`--second`, the paper's fuzzy
fiber surfaces), written from the SPEC, not from the C++.

Two models on one grid, x from the first and y from the second, the fields independent of each
other; each field's distribution at a point is its model's of SPEC §3 (reference.RefModel), and
the classification is E[(α·c, α)] of a raster TF2 (reference2d.TF2) over the product of the two.

Method: a 1D quadrature rule per field (`field_rule`: nodes and weights in data units) that
integrates g(X) exactly for every g that is a quadratic between consecutive raster lines of its
axis and constant beyond the outer ones (the TF2 clamps). Inside a raster cell α and c are each
bilinear, so α·c is a biquadratic: with X and Y independent, the tensor product of the two rules
is exact, E = Σ_a Σ_b w_a w_b TF2(x_a, y_b). Pieces of each distribution are split at every
raster line and integrated with Gauss–Legendre against their density:
- point masses (mean, quantile-mean's midpoints, zero-width quantiles, σ = 0): the point;
- uniform pieces (the quantile-range family): 3 nodes per piece (exact to degree 5);
- normal (gaussian, each gmm-ordered component): [μ ± 10σ] in pieces of σ/2, 12 nodes each
  (the mass beyond, 2e−23, is dropped);
- box spline (uniform): reference.uniform_sum_cdf's exact Chebyshev pieces, 8 nodes per piece
  (density degree ≤ 7, times a quadratic: exact).
"""
import math

import numpy as np
from numpy.polynomial import chebyshev as C

import reference as ref

_GL = {n: np.polynomial.legendre.leggauss(n) for n in (3, 8, 12)}
_INV_SQRT_2PI = 1.0 / math.sqrt(2.0 * math.pi)

QUANTILE_RANGE_KINDS = ("quantile-range", "quartile-lower", "quartile-middle", "quartile-upper",
                        "iqr")
# Every model of the model table (udvr.models()) that renders bivariate fields, by CLI name → the
# distribution of each field (SPEC §3) this module evaluates for it (field_rule; "members": the
# members' values at the point, 1/n each, m a reference.RefMembers). A fast form, its alias and
# its exact form share one. test_reference_coverage.py fails for a row of the table that is
# neither here nor in NO_REFERENCE: adding a model adds its reference.
MODELS = dict({k: k for k in ("mean", "uniform", "gaussian", "gmm-ordered", "quantile-mean",
                              "quantile-mean-mass", "members") + QUANTILE_RANGE_KINDS},
              **{"uniform-fast": "uniform", "uniform-exact": "uniform",
                 "gaussian-exact": "gaussian"})
# Rows of the table with bivariate fields and no reference here, with why (none today).
NO_REFERENCE = {}


def _pieces_rule(edges, density, lines, n):
    """Nodes and weights of ∫ g·density over [edges[0], edges[-1]], split at `edges` and at
    every raster line inside, n Gauss–Legendre nodes per piece."""
    cuts = np.unique(np.concatenate([edges, lines[(lines > edges[0]) & (lines < edges[-1])]]))
    l, r = cuts[:-1], cuts[1:]
    keep = r > l
    l, r = l[keep], r[keep]
    gx, gw = _GL[n]
    x = 0.5 * (l + r)[:, None] + 0.5 * (r - l)[:, None] * gx[None, :]
    w = 0.5 * (r - l)[:, None] * gw[None, :] * density(x)
    return x.ravel(), w.ravel()


def _normal_rule(mu, sigma, lines, mass=1.0):
    if not sigma > 0:
        return np.array([mu]), np.array([mass])
    edges = mu + sigma * np.arange(-20, 21) * 0.5
    x, w = _pieces_rule(edges, lambda x: np.exp(-0.5 * ((x - mu) / sigma) ** 2)
                        * _INV_SQRT_2PI / sigma, lines, 12)
    return x, mass * w


def _uniform_pieces_rule(b, lines, share):
    """Quantile j uniform on [b_j, b_{j+1}] with probability share[j]."""
    xs, ws = [], []
    for a, c, mass_each in zip(b[:-1], b[1:], share):
        if c > a:
            x, w = _pieces_rule(np.array([a, c]), lambda x: np.full_like(x, 1.0 / (c - a)),
                                lines, 3)
        else:
            x, w = np.array([a]), np.array([1.0])
        xs.append(x)
        ws.append(mass_each * w)
    return np.concatenate(xs), np.concatenate(ws)


def _box_spline_rule(shift, widths, tiny, lines):
    widths = np.asarray(widths, float)
    shift = float(shift) + 0.5 * float(np.sum(widths[widths <= tiny]))
    ws = np.sort(widths[widths > tiny])[::-1]
    if len(ws) == 0:
        return np.array([shift]), np.array([1.0])
    cdf = ref.uniform_sum_cdf(ws)
    dens = cdf.density_pieces()

    def density(x):
        i, u, _ = cdf._locate((x - shift).ravel())
        return C.chebval(u, dens[:, i], tensor=False).reshape(x.shape)

    return _pieces_rule(shift + cdf.edges, density, lines, 8)


def field_rule(m, kind, p, lines, uniform_width="variance"):
    """(nodes, weights) of the distribution of model m (reference.RefModel) under `kind` at one
    index-space point p (3,), exact for g quadratic between the raster `lines` (see above)."""
    p = np.atleast_2d(np.asarray(p, float))
    kind = MODELS.get(kind, kind)  # a CLI name → its distribution
    if kind == "members":  # atoms 1/n at each member's trilinear value
        values = np.array([f.mean_at(p)[0] for f in m.fields])
        return values, np.full(len(values), 1.0 / len(values))
    lo, hi = m.data_range()
    R = hi - lo
    if kind == "mean":
        return m.mean_at(p), np.ones(1)
    if kind == "gaussian":
        mu, sg = m.gaussian_at(p)
        return _normal_rule(mu[0], sg[0], lines)
    if kind == "gmm-ordered":
        idx, w = m.corners(p)
        K = m.gmm.shape[-1] // 3
        par = m._lerp(m.gmm, idx, w)[0]
        pi, mu, sg = par[:K], par[K:2 * K], par[2 * K:]
        if pi.sum() > 0:
            pi = pi / pi.sum()
        rules = [_normal_rule(mu[k], sg[k], lines, pi[k]) for k in range(K) if pi[k] != 0]
        if not rules:
            return np.zeros(1), np.zeros(1)
        return np.concatenate([r[0] for r in rules]), np.concatenate([r[1] for r in rules])
    if kind == "uniform":
        idx, w = m.corners(p)
        if uniform_width == "minmax":
            l_c, h_c = m.vmin.ravel()[idx[0]], m.vmax.ravel()[idx[0]]
        else:
            m_c, s_c = m.mean.ravel()[idx[0]], m.stddev.ravel()[idx[0]]
            l_c, h_c = m_c - ref.SQRT3 * s_c, m_c + ref.SQRT3 * s_c
        keep = w[0] > 0
        return _box_spline_rule(np.sum(w[0][keep] * l_c[keep]), w[0][keep] * (h_c - l_c)[keep],
                                1e-9 * max(R, 1e-30), lines)
    if kind in QUANTILE_RANGE_KINDS:
        b = m.boundaries_at(p, "iqr" if kind == "iqr" else "quantiles")[0]
        j0, j1, share = m.population(kind)
        return _uniform_pieces_rule(b[j0:j1 + 1], lines, share)
    if kind in ("quantile-mean", "quantile-mean-mass"):
        b = m.boundaries_at(p)[0]
        return 0.5 * (b[1:] + b[:-1]), m.quantile_mean_weights(np.diff(b), kind)
    raise ValueError("no bivariate classification for model " + kind)


def classify_bivariate(m1, m2, kind, tf2, p, uniform_width="variance"):
    """(N, 4) E[(α·r, α·g, α·b, α)] of TF2(X, Y) at index-space points p (N, 3), X from m1 and
    Y from m2 independent, both under `kind`."""
    out = []
    for q in np.atleast_2d(np.asarray(p, float)):
        xa, wa = field_rule(m1, kind, q, tf2.xs, uniform_width)
        yb, wb = field_rule(m2, kind, q, tf2.ys, uniform_width)
        v = tf2(xa[:, None], yb[None, :])  # (A, B, 4)
        out.append(np.einsum("a,b,abc->c", wa, wb, v))
    return np.array(out)


def field_moments(m, kind, p, uniform_width="variance"):
    """Mean and standard deviation of the field's distribution at p (the probe's second field)."""
    x, w = field_rule(m, kind, p, np.array([]), uniform_width)
    mean = np.sum(w * x) / np.sum(w)
    return mean, math.sqrt(max(np.sum(w * x * x) / np.sum(w) - mean * mean, 0.0))


class _Bivariate:
    """A RefModel pair whose classify(kind, tf2, p) is the bivariate one, for reference.render
    (geometry from the first)."""

    def __init__(self, m1, m2):
        self._m, self._m2 = m1, m2

    def __getattr__(self, name):
        return getattr(self._m, name)

    def classify(self, kind, tf2, p):
        return classify_bivariate(self._m, self._m2, kind, tf2, p).reshape(-1, 4)


def render_bivariate(m1, m2, kind, tf2, width, height, cam, **kw):
    """reference.render (SPEC §5) with the bivariate classification per sample."""
    return ref.render(_Bivariate(m1, m2), kind, tf2, width, height, cam, **kw)
