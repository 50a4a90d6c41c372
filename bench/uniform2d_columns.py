#!/usr/bin/env python3
"""Issue 33, the 2D `uniform`: an evaluation by columns, tried in NumPy against `uniform-exact`.

The 2D uniform's law is the bivariate box spline (X, G) = c + Σ_i t_i·d_i, t_i ~ U[−1, 1]
(SPEC §9; d_i = (w_i, u_i)·√3σ_i over the 32-voxel linear form). The TF2 T is bilinear, so in
raster cells T(x, g) = Σ_k hat(x − k)·T_k(g), T_k the point column k (piecewise linear in g,
clamped), and exactly

    E[T(X, G)] = Σ_k M_k · E_k[T_k(G)],   M_k = E[hat(X − k)],

E_k the law of G weighted by hat(X − k) (its moments E[hat(X − k)·G^j] / M_k). Only the ≤ 8
corners (w_i > 0) move X. This script builds those moments on a fine x grid (each corner box
deposited at `sub` points, cloud-in-cell at spacing `delta` cells: converged well below the
errors shown), and takes each column's law of G as
    μ_k + (the widest G-only box, exact) + N(0, s_k²) with the Edgeworth κ3, κ4 terms
(the corners' conditional cumulants from the moments, the other G-only boxes' κ4 = −2b⁴/15), in
closed form per raster point of the column through its ramp response R(u) = E[(u + Y)_+]:
E_k[T_k(G)] = T_k(g_0) + Σ_j Δslope_j·R(μ_k − g_j).

by_columns_keeping also integrates the box of the largest G extent by Gauss–Legendre where it
holds over a quarter of var G. It prints, per point and in summary, |Δ E[α]| against
`uniform-exact` (the probe's converged evaluation) for both forms and for today's `uniform`. It is a study for a fast kernel (the numbers
are in docs/models.md, "2D uniform by columns"), not a kernel: the fine grid and the sums over
every raster point cost ~0.1 s a point here.

  PYTHONPATH=build/python python3 bench/uniform2d_columns.py MODEL.vti TF2.json --points 200
  PYTHONPATH=build/python python3 bench/uniform2d_columns.py - TF2.json --fourier 300

--fourier checks the cheaper column sums a kernel would take where the law is wide in G: each
column's Fourier coefficients, computed once per TF2, times the law's characteristic function.
"""
import argparse
import math
import pathlib
import sys

import numpy as np
from scipy.special import ndtr

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "python" / "tests"))
import reference as ref  # noqa: E402  (the independent NumPy reference of SPEC §3)
import reference2d as r2  # noqa: E402  (… and of SPEC §9: the 32-voxel linear form)
import udvr  # noqa: E402

SQRT_2PI = math.sqrt(2.0 * math.pi)


def box_spline_at(model, p):
    """(cx, cg, directions (n, 2)) of the 2D uniform at index point p, data units (SPEC §9)."""
    s = r2.Sample2D(model, np.asarray(p, float)[None])
    half = math.sqrt(3.0) * model.stddev.ravel()[s.idx[0]]
    d = np.stack([s.w[0] * half, s.u[0] * half], axis=1)
    keep = np.any(d != 0.0, axis=1)
    return float(s.xbar[0]), float(np.dot(s.nhat[0], s.mu_y[0])), d[keep]


def ramp_response(u, s, k3, k4, half):
    """R(u) = E[(u + Y)_+] for Y = box(half) + N(0, s²) with the Edgeworth terms κ3, κ4 of the
    normal part (density (1 − κ3/6·D³ + κ4/24·D⁴)φ_s, so R'' = φ_s + κ3/6·φ_s' + κ4/24·φ_s'').
    Without the box (half = 0): s·ψ(u/s), ψ(z) = zΦ(z) + φ(z); with it, the box's average of
    that, through the antiderivative s²·((z² + 1)Φ(z) + zφ(z))/2."""
    def normal_ramp(v):
        z = v / s
        ph = np.exp(-0.5 * z * z) / SQRT_2PI
        return (s * (z * ndtr(z) + ph) + k3 / 6 * (-z / s * ph / s)
                + k4 / 24 * ((z * z - 1) / (s * s) * ph / s))

    def antiderivative(v):
        z = v / s
        ph = np.exp(-0.5 * z * z) / SQRT_2PI
        return (s * s * ((z * z + 1) * ndtr(z) + z * ph) / 2 + k3 / 6 * (ph / s)
                + k4 / 24 * (-z / s * ph / s))

    if half <= 0.0:
        return normal_ramp(u)
    return (antiderivative(u + half) - antiderivative(u - half)) / (2.0 * half)


def corner_moments(a, b, cx, delta, sub):
    """Moments E[δ(X − x)·G_c^j], j = 0 … 4, of the corner boxes (a_i, b_i) (raster cells; G_c
    their part of G) on the grid x = cx + delta·i: each box deposited at `sub` midpoints of t,
    cloud in cell."""
    A = np.abs(a).sum()
    n = int(math.ceil(A / delta)) + 2
    xs = cx + delta * np.arange(-n, n + 1)
    M = np.zeros((5, 2 * n + 1))
    M[0, n] = 1.0
    ts = (np.arange(sub) + 0.5) / sub * 2.0 - 1.0
    for ai, bi in zip(a, b):
        out = np.zeros_like(M)
        for t in ts:
            shift = ai * t / delta
            k = int(math.floor(shift))
            f = shift - k
            g = bi * t
            S = np.zeros_like(M)  # E[(G + g)^j] from E[G^q]
            for j in range(5):
                for q in range(j + 1):
                    S[j] += math.comb(j, q) * g ** (j - q) * M[q]
            out += ((1 - f) * np.roll(S, k, axis=1) + f * np.roll(S, k + 1, axis=1)) / sub
        M = out
    keep = M[0] > 1e-15
    return xs[keep], M[:, keep]


def by_columns(raster, domain, cx, cg, d, delta=0.02, sub=64):
    """E[(α·c, α)] by columns (module docstring); raster (H, W, 4), domain (x0, x1, y0, y1)."""
    H, W, _ = raster.shape
    x0, x1, y0, y1 = domain
    sx, sy = (W - 1) / (x1 - x0), (H - 1) / (y1 - y0)  # cells per data unit
    a, b = d[:, 0] * sx, d[:, 1] * sy
    corner = np.abs(a) > 1e-9 * max(1.0, np.abs(a).max())
    xs, M = corner_moments(a[corner], b[corner], (cx - x0) * sx, delta, sub)
    m0 = M[0]
    mu = M[1] / m0
    c2 = M[2] / m0 - mu ** 2
    c3 = M[3] / m0 - 3 * mu * M[2] / m0 + 2 * mu ** 3
    c4 = M[4] / m0 - 4 * mu * M[3] / m0 + 6 * mu ** 2 * M[2] / m0 - 3 * mu ** 4
    gonly = np.abs(b[~corner])
    half = 0.0
    if len(gonly):
        half = float(gonly.max())
        gonly = np.delete(gonly, gonly.argmax())
    s = np.sqrt(np.maximum(c2 + (gonly ** 2).sum() / 3.0, 1e-24))
    k4 = (c4 - 3 * c2 ** 2) - 2.0 / 15.0 * (gonly ** 4).sum()
    mu = mu + (cg - y0) * sy
    xc = np.clip(xs, 0, W - 1)
    col = np.minimum(np.floor(xc).astype(int), W - 2)
    f = xc - col
    g = np.arange(H, dtype=float)
    out = np.zeros(4)
    for c in np.unique(col):
        sel = col == c
        R = ramp_response(mu[sel, None] - g[None, :], s[sel, None], c3[sel, None], k4[sel, None],
                          half)
        for side, weight in ((c, 1 - f[sel]), (c + 1, f[sel])):
            T = raster[:, side, :].astype(float)  # (H, 4) the point column
            slope = np.diff(T, axis=0)
            kink = np.diff(np.vstack([np.zeros((1, 4)), slope, np.zeros((1, 4))]), axis=0)
            e = T[0][None, :] + R @ kink  # (nodes, 4)
            out += ((m0[sel] * weight)[:, None] * e).sum(axis=0)
    return out


def by_columns_keeping(raster, domain, cx, cg, d, share=0.25, pieces=2, nodes=8):
    """by_columns, with the box of the largest G extent integrated by Gauss–Legendre (`pieces`
    pieces of `nodes` points over t ∈ [−1, 1]) where its share of var G is over `share`: the
    conditional law of G is then far from a normal with κ3, κ4 (e.g. a corner narrow in x and
    wide in G, or two wide corners of different slopes)."""
    H, W, _ = raster.shape
    sy = (H - 1) / (domain[3] - domain[2])
    k = int(np.argmax(np.abs(d[:, 1])))
    if d[k, 1] ** 2 <= share * (d[:, 1] ** 2).sum() or abs(d[k, 1]) * sy < 1.0:
        return by_columns(raster, domain, cx, cg, d), False
    rest = np.delete(d, k, axis=0)
    x, w = np.polynomial.legendre.leggauss(nodes)
    out = np.zeros(4)
    for piece in range(pieces):
        lo = -1.0 + 2.0 * piece / pieces
        hi = lo + 2.0 / pieces
        for xi, wi in zip(x, w):
            t = lo + (xi + 1.0) / 2.0 * (hi - lo)
            out += wi * (hi - lo) / 4.0 * by_columns(raster, domain, cx + t * d[k, 0],
                                                     cg + t * d[k, 1], rest)
    return out, True


def column_fourier(col, pad, back, terms):
    """Fourier coefficients of a point column (clamped, piecewise linear in g, raster cells) made
    periodic: kept on [−pad, H − 1 + pad], then a straight return over `back` cells. Returns
    (c_0, c_1 … c_terms, ω_m, period); exact (the kinks' closed form, c_m = −Σ Δslope·e^{−iωg}
    / (Lω²))."""
    H = len(col)
    g = np.concatenate([[-pad], np.arange(H, dtype=float), [H - 1 + pad, H - 1 + pad + back]])
    v = np.concatenate([[col[0]], col, [col[-1], col[0]]])
    period = H - 1 + 2 * pad + back
    slope = np.diff(v) / np.diff(g)
    kink = np.diff(np.concatenate([[slope[-1]], slope]))
    w = 2 * np.pi * np.arange(1, terms + 1) / period
    c = -(kink[None, :] * np.exp(-1j * w[:, None] * (g[:-1][None, :] + pad))).sum(1)
    c /= period * w * w
    c0 = (0.5 * (v[:-1] + v[1:]) * np.diff(g)).sum() / period
    return c0, c, w, period


def fourier_check(raster, cases, seed, pad=1200, back=256):
    """E_k[T_k(μ + Y)] from the columns' Fourier coefficients (per TF2) against the ramp sums, for
    random laws (s from 0.3 to 150 cells, a box of half-width up to 150 half the time, κ3, κ4):
    the agreement, and how many terms reach 1e−6, by s."""
    H, W, _ = raster.shape
    rng = np.random.default_rng(seed)
    y = np.arange(H, dtype=float)
    rows = {}
    for _ in range(cases):
        col = raster[:, rng.integers(0, W), 3]
        if col.max() == 0:
            continue
        s = math.exp(rng.uniform(math.log(0.3), math.log(150.0)))
        half = rng.uniform(0, 150) if rng.random() < 0.5 else 0.0
        mu = rng.uniform(-50, H + 50)
        k3, k4 = rng.uniform(-0.3, 0.3) * s ** 3, rng.uniform(-0.6, 0.2) * s ** 4
        c0, c, w, _ = column_fourier(col, pad, back, 4096)
        chi = np.exp(-0.5 * (s * w) ** 2) * (1 - 1j * k3 * w ** 3 / 6 + k4 * w ** 4 / 24)
        if half > 0:
            chi = chi * np.sin(half * w) / (half * w)
        terms = 2 * (c * np.exp(1j * w * (mu + pad)) * chi).real
        R = ramp_response(np.array([[mu]]) - y[None, :], np.array([[s]]), np.array([[k3]]),
                          np.array([[k4]]), half)
        slope = np.concatenate([[0.0], np.diff(col), [0.0]])
        ramp = col[0] + (R[0] * np.diff(slope)).sum()
        tail = np.abs(np.cumsum(terms[::-1]))[::-1]
        need = int(np.argmax(tail < 1e-6)) if (tail < 1e-6).any() else len(tail)
        rows.setdefault(int(math.floor(math.log2(s))), []).append((abs(c0 + terms.sum() - ramp),
                                                                    need))
    for k in sorted(rows):
        v = np.array(rows[k])
        print("s in [%g, %g) cells: %3d laws, max |Fourier - ramp| %.1e, terms for 1e-6: median "
              "%d, max %d" % (2.0 ** k, 2.0 ** (k + 1), len(v), v[:, 0].max(), np.median(v[:, 1]),
                              v[:, 1].max()))
    print("period %d cells (pad %d, back %d)" % (H - 1 + 2 * pad + back, pad, back))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("model")
    ap.add_argument("tf2")
    ap.add_argument("--fourier", type=int, default=0, metavar="N",
                    help="instead: check the columns' Fourier form on N random laws (no model "
                         "read)")
    ap.add_argument("--points", type=int, default=100)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--min-alpha", type=float, default=1e-4,
                    help="skip points whose exact E[α] is below this (the TF2's empty part)")
    args = ap.parse_args()
    if args.fourier:
        raster = np.asarray(udvr.TransferFunction2D.read(args.tf2).raster, float)
        fourier_check(raster, args.fourier, args.seed)
        return
    m = udvr.load(args.model)
    g = m.grid
    model = ref.RefModel(np.asarray(m.mean, float), np.asarray(m.stddev, float),
                         origin=g.origin, spacing=g.spacing)
    tf = udvr.TransferFunction2D.read(args.tf2)
    raster = np.asarray(tf.raster, float)
    domain = (tf.x0, tf.x1, tf.y0, tf.y1)
    rng = np.random.default_rng(args.seed)
    dims = np.array(g.dims)
    rows = []
    tries = 0
    while len(rows) < args.points and tries < 50 * args.points:
        tries += 1
        p = rng.uniform(1.0, dims - 2.0)
        exact = m.probe(p, "uniform-exact", tf)["expected_rgba"][3]
        if exact < args.min_alpha:
            continue
        fast = m.probe(p, "uniform", tf)["expected_rgba"][3]
        cx, cg, d = box_spline_at(model, p)
        cols = by_columns(raster, domain, cx, cg, d)[3]
        kept, used = by_columns_keeping(raster, domain, cx, cg, d)
        rows.append((exact, fast - exact, cols - exact, kept[3] - exact, used))
        print("p=(%6.2f %6.2f %6.2f) E[α] %.5f  uniform %+.2e  by columns %+.2e  keeping %+.2e%s"
              % (*p, exact, fast - exact, cols - exact, kept[3] - exact, " (kept)" if used else ""),
              flush=True)
    e = np.abs(np.array(rows))
    print("the widest-in-G box kept at %d of %d points" % (e[:, 4].sum(), len(e)))
    for name, k in (("uniform", 1), ("by columns", 2), ("keeping", 3)):
        print("%-10s max %.3e  mean %.3e  over 1e-3: %d of %d"
              % (name, e[:, k].max(), e[:, k].mean(), (e[:, k] > 1e-3).sum(), len(e)))


if __name__ == "__main__":
    main()
