"""Random models, transfer functions and points for the reference tests, and the CLI runner."""
import json
import os
import pathlib
import subprocess
from concurrent.futures import ThreadPoolExecutor

import numpy as np

import reference as ref

ROOT = pathlib.Path(__file__).resolve().parents[2]


def udvr_binary():
    """The udvr executable: $UDVR_BINARY, else $UDVR_BUILD_DIR/udvr, else build/udvr."""
    if os.environ.get("UDVR_BINARY"):
        return os.environ["UDVR_BINARY"]
    build = pathlib.Path(os.environ.get("UDVR_BUILD_DIR", ROOT / "build"))
    if not build.is_absolute():
        build = ROOT / build
    return str(build / "udvr")


def run_udvr(*args):
    """Run udvr; returns stdout. Fails with the command's stderr on a non-zero exit."""
    cmd = [udvr_binary()] + [str(a) for a in args]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    if p.returncode != 0:
        raise AssertionError("%s failed (%d):\n%s" % (" ".join(cmd), p.returncode, p.stderr))
    return p.stdout


def fmt(v):
    """x,y,z with full float64 precision (repr)."""
    return ",".join(repr(float(x)) for x in v)


def random_tf(rng, lo, hi, steps=True):
    """Random colour and opacity points over [lo − 0.3R, hi + 0.3R] (beyond the data range),
    with a step in each (two points at one x) when `steps`, exact zeros in opacity, and points
    at least 0.02·R apart otherwise."""
    R = hi - lo

    def xs(n):
        while True:
            x = np.sort(rng.uniform(lo - 0.3 * R, hi + 0.3 * R, n))
            if n < 2 or np.diff(x).min() > 0.02 * R:
                break
        if steps and n >= 3:
            k = int(rng.integers(1, n - 1))
            x = np.insert(x, k, x[k])  # a step at x[k]
        return x

    cx = xs(int(rng.integers(2, 6)))
    rgb = rng.uniform(0, 1, (len(cx), 3))
    ox = xs(int(rng.integers(2, 7)))
    alpha = rng.uniform(0, 1, len(ox))
    alpha[rng.random(len(ox)) < 0.3] = 0.0
    if alpha.max() == 0.0:
        alpha[len(alpha) // 2] = 0.7
    return ref.TF(cx, rgb, ox, alpha)


def random_model_arrays(rng, dims, q=8, K=3):
    """Arrays (float32, shape (Z,Y,X[,c])) of a random model with ties and point masses.
    Returns a dict of constructor arguments for both udvr.Model and reference.RefModel."""
    X, Y, Z = dims
    shape = (Z, Y, X)
    lo = rng.uniform(-5, 5)
    scale = rng.uniform(0.5, 10)
    mean = lo + scale * rng.random(shape)
    stddev = scale * rng.uniform(0, 0.3, shape)
    stddev[rng.random(shape) < 0.15] = 0.0
    vmin = mean - scale * rng.uniform(0, 0.5, shape)
    vmax = mean + scale * rng.uniform(0, 0.5, shape)
    # Quantile boundaries: b_0 near the mean, increments with exact ties; some point masses.
    inc = scale * rng.exponential(0.05, shape + (q,))
    inc[rng.random(shape + (q,)) < 0.15] = 0.0
    b = (mean - 0.5 * inc.sum(-1))[..., None] + np.concatenate(
        [np.zeros(shape + (1,)), np.cumsum(inc, -1)], -1)
    point_mass = rng.random(shape) < 0.1
    b[point_mass] = mean[point_mass][:, None]
    iqr = np.stack([b[..., q // 4], b[..., 3 * q // 4]], -1)
    # GMM: π (Dirichlet), μ sorted, σ in [1e−3, 0.2]·scale.
    pi = rng.dirichlet(np.ones(K), shape)
    mu = np.sort(mean[..., None] + scale * rng.normal(0, 0.3, shape + (K,)), -1)
    sg = scale * rng.uniform(1e-3, 0.2, shape + (K,))
    gmm = np.concatenate([pi, mu, sg], -1)
    f32 = lambda a: np.ascontiguousarray(a, dtype=np.float32)
    return dict(mean=f32(mean), stddev=f32(stddev), min=f32(vmin), max=f32(vmax),
                quantiles=f32(b), iqr=f32(iqr), gmm=f32(gmm))


def make_models(udvr, arrays, origin, spacing, bounds=None, full_res_min_spacing=None,
                levels=None):
    """(udvr.Model, reference.RefModel) from the same float32 arrays; `levels`: uneven quantile
    levels t_0 = 0 … t_q = 1 (None: even)."""
    m = udvr.Model(arrays["mean"], stddev=arrays["stddev"], min=arrays["min"], max=arrays["max"],
                   quantiles=arrays["quantiles"], iqr=arrays["iqr"], gmm=arrays["gmm"],
                   origin=list(origin), spacing=list(spacing),
                   bounds=None if bounds is None else list(bounds),
                   full_res_min_spacing=full_res_min_spacing,
                   quantile_levels=[] if levels is None else [float(t) for t in levels])
    r = ref.RefModel(arrays["mean"], stddev=arrays["stddev"], vmin=arrays["min"],
                     vmax=arrays["max"], quantiles=arrays["quantiles"], iqr=arrays["iqr"],
                     gmm=arrays["gmm"], origin=origin, spacing=spacing, bounds=bounds,
                     full_res_min_spacing=full_res_min_spacing, levels=levels)
    return m, r


def probe_json(model_path, tf_path, kind, point):
    out = run_udvr("probe", model_path, "--point", fmt(point), "--model", kind, "--tf", tf_path,
                   "--json")
    return json.loads(out)


def probe_many(model_path, tf_path, kind, points, extra=()):
    """probe_json at several points, a few processes at a time (their start-up dominates)."""
    def one(p):
        return json.loads(run_udvr("probe", model_path, "--point", fmt(p), "--model", kind,
                                   "--tf", tf_path, "--json", *extra))
    with ThreadPoolExecutor(max_workers=4) as ex:
        return list(ex.map(one, points))


def random_points(rng, dims, n):
    """Interior points, then a face, an edge and a corner point; float32-exact coordinates."""
    hi = np.asarray(dims, float) - 1
    pts = [rng.uniform(0, 1, 3) * hi for _ in range(n)]
    face = rng.uniform(0, 1, 3) * hi
    ax = rng.integers(3)
    face[ax] = hi[ax] if rng.random() < 0.5 else 0.0
    edge = rng.uniform(0, 1, 3) * hi
    a, b = rng.choice(3, 2, replace=False)
    edge[a], edge[b] = 0.0, hi[b]
    corner = hi * rng.integers(0, 2, 3)
    integer = np.array([rng.integers(0, d) for d in dims], float)  # a grid point
    pts += [face, edge, corner, integer]
    return [np.asarray(p, np.float32).astype(float) for p in pts]


def random_camera(rng, r, kind):
    """CLI arguments and the reference camera of one random camera of `kind`."""
    b = r.bounds
    c = 0.5 * (b[0::2] + b[1::2])
    radius = 0.5 * np.linalg.norm(b[1::2] - b[0::2])
    if kind == "default":
        az, el, zoom = rng.uniform(-180, 180), rng.uniform(-60, 60), rng.uniform(0.9, 1.6)
        va = rng.uniform(20, 40)
        cam = ref.default_camera(b, az, el, zoom, va)
        args = ["--azimuth", repr(az), "--elevation", repr(el), "--zoom", repr(zoom),
                "--view-angle", repr(va)]
        return args, cam, None
    if kind == "default-parallel":
        az, el = rng.uniform(-180, 180), rng.uniform(-60, 60)
        cam = ref.default_camera(b, az, el)
        ps = radius * rng.uniform(0.6, 1.1)
        args = ["--azimuth", repr(az), "--elevation", repr(el), "--parallel-scale", repr(ps)]
        return args, cam, ps
    d = rng.normal(size=3)
    d /= np.linalg.norm(d)
    focal = c + 0.15 * radius * rng.normal(size=3)
    pos = focal + d * radius * rng.uniform(2.2, 3.5)
    up = rng.normal(size=3)
    va = rng.uniform(25, 45)
    cam = dict(position=pos, focal_point=focal, view_up=up, view_angle=va)
    args = ["--position", fmt(pos), "--focal-point", fmt(focal), "--view-up",
            fmt(up), "--view-angle", repr(va)]
    ps = None
    if kind == "parallel":
        ps = radius * rng.uniform(0.6, 1.1)
        args += ["--parallel-scale", repr(ps)]
    return args, cam, ps
