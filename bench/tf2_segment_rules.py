#!/usr/bin/python3
"""What quantile-range's exact segment means cost against O(q) rules (issue 10 point 4).

SPEC §9's quantile-range takes the exact mean of the TF2 along each of the q segments of a
sample's polyline (X(t), G(t)); exactly, that reads every raster cell the segment crosses. This
script measures, on a model and a TF2, (1) how many cells a polyline crosses (the exact walk's
pieces; a walk banded along the axis each segment crosses fewer lines of would take Σ min) and
(2) how far fixed-node rules — K-point Gauss–Legendre per segment, O(q·K) lookups — are from the
exact mean. Polylines are taken at random grid points (the renderer's samples are trilinear
between them) whose x range meets a raster column with α > 0 (the others are skipped by the
renderer). The exact means come from python/tests/reference2d.py, independent of the C++.

    PYTHONPATH=build/python:python/tests /usr/bin/python3 bench/tf2_segment_rules.py \
        MODEL.vti data/tf2/tangle.json [--polylines 4000] [--seed 0]
"""
import argparse
import sys

import numpy as np

import reference2d as ref2
import udvr


def polylines(model):
    """Vertices (X_j, G_j) of every grid point's polyline, (Z, Y, X, q + 1) each (SPEC §9)."""
    spacing = model.grid.spacing
    g_mean = ref2.grid_gradients(np.asarray(model.mean, float), spacing)
    norm = np.linalg.norm(g_mean, axis=-1, keepdims=True)
    n_hat = np.where(norm > 0, g_mean / np.where(norm > 0, norm, 1.0), [1.0, 0.0, 0.0])
    q = np.asarray(model.quantiles, float)
    g = np.stack([(ref2.grid_gradients(q[..., j], spacing) * n_hat).sum(-1)
                  for j in range(q.shape[-1])], -1)
    return q, g


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("model")
    ap.add_argument("tf2")
    ap.add_argument("--polylines", type=int, default=4000)
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    model = udvr.read_model(a.model)
    t = udvr.TransferFunction2D.read(a.tf2)
    tf2 = ref2.TF2(t.raster, (t.x0, t.x1, t.y0, t.y1))
    X, G = polylines(model)
    X = X.reshape(-1, X.shape[-1])
    G = G.reshape(-1, G.shape[-1])
    # raster coordinates, clamped as the TF2 is
    sx = np.clip((X - tf2.x0) / tf2.dx, 0, tf2.W - 1)
    sy = np.clip((G - tf2.y0) / tf2.dy, 0, tf2.H - 1)
    cols = np.nonzero((tf2.rgba[..., 3] > 0).any(0))[0]
    meets = (sx.max(1) >= cols.min() - 1) & (sx.min(1) <= cols.max() + 1)
    rng = np.random.default_rng(a.seed)
    pick = rng.permutation(np.nonzero(meets)[0])[:a.polylines]
    if len(pick) == 0:
        sys.exit("tf2_segment_rules.py: no polyline meets the TF2's columns with alpha > 0")
    X, G, sx, sy = X[pick], G[pick], sx[pick], sy[pick]
    dx, dy = np.abs(np.diff(sx, axis=1)), np.abs(np.diff(sy, axis=1))
    q = X.shape[1] - 1
    print(f"{len(pick)} polylines of {q} segments ({meets.sum()} of {len(meets)} grid points "
          f"meet the alpha > 0 columns), raster {tf2.W}x{tf2.H}")
    print(f"raster lines crossed per polyline: x {dx.sum(1).mean():.1f}, y {dy.sum(1).mean():.1f},"
          f" both {(dx + dy).sum(1).mean():.1f}; sum of min(x, y) per segment "
          f"{np.minimum(dx, dy).sum(1).mean():.1f}")
    P = np.stack([X, G], -1)
    exact = ref2.mean_along_segment(tf2, P[:, :-1], P[:, 1:]).mean(1)  # (N, 4)
    print(f"exact E[alpha]: mean {exact[:, 3].mean():.4f}, max {exact[:, 3].max():.4f}")
    print("K nodes | max |dE[alpha]| | rms | max |dE[alpha c]| over r, g, b")
    for K in (2, 4, 8, 16, 32):
        x, w = np.polynomial.legendre.leggauss(K)
        u = (x + 1) / 2
        pts = P[:, :-1, None, :] + u[None, None, :, None] * (P[:, 1:] - P[:, :-1])[:, :, None, :]
        rule = np.einsum("k,nskc->nc", w / 2, tf2(pts[..., 0], pts[..., 1])) / q
        e = rule - exact
        print(f"{K:7d} | {np.abs(e[:, 3]).max():.2e} | {np.sqrt((e[:, 3] ** 2).mean()):.2e} | "
              f"{np.abs(e[:, :3]).max():.2e}")


if __name__ == "__main__":
    main()
