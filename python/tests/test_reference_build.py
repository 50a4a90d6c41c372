"""`udvr build` statistics (SPEC §2) against NumPy on random ensembles and bricks: mean, stddev
(ddof=1), min, max, quantile boundaries (empirical: numpy's linear quantiles; kde: inverse of a
Gaussian KDE CDF with Silverman's robust, Scott's or a given bandwidth and ε = 1/(2n) tails),
the iqr array, and the geometry of a downsampled model (brick centres, k·spacing, full-res
bounds)."""
import numpy as np
import pytest
from scipy.special import ndtr

import refcase

udvr = pytest.importorskip("udvr")


def random_members(rng, dims, n):
    """(n, Z, Y, X) float32 members: Gaussian, bimodal, tied and constant voxels."""
    X, Y, Z = dims
    base = rng.uniform(-2, 3, (Z, Y, X))
    v = base + rng.normal(0, 0.4, (n, Z, Y, X))
    bimodal = rng.random((Z, Y, X)) < 0.3
    v = np.where(bimodal & (rng.random((n, Z, Y, X)) < 0.3), v + 2.0, v)
    ties = rng.random((Z, Y, X)) < 0.2
    v = np.where(ties, np.round(v * 2) / 2, v)
    const = rng.random((Z, Y, X)) < 0.1
    v = np.where(const, base, v)
    return v.astype(np.float32)


def build(tmp_path, members, *args):
    paths = []
    for i, m in enumerate(members):
        p = tmp_path / ("m%02d.vti" % i)
        udvr.write_field(str(p), udvr.Field(m, [0.5, -1.0, 2.0], [1.0, 0.5, 2.0]))
        paths.append(p)
    out = tmp_path / "model.vti"
    refcase.run_udvr("build", *paths, "--gmm", "0", *args, "-o", out)
    return udvr.read_model(str(out))


def kde_quantiles(s, probs, h):
    """F⁻¹(probs) of the Gaussian KDE of samples s (V, n) with bandwidths h (V,); bisection."""
    V, n = s.shape
    lo = s.min(1)[:, None] - 12 * h[:, None] * np.ones(len(probs))
    hi = s.max(1)[:, None] + 12 * h[:, None] * np.ones(len(probs))
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        F = ndtr((mid[:, :, None] - s[:, None, :]) / h[:, None, None]).mean(-1)
        below = F < probs[None, :]
        lo = np.where(below, mid, lo)
        hi = np.where(below, hi, mid)
    return 0.5 * (lo + hi)


@pytest.mark.parametrize("n", [5, 12])
def test_empirical_build_matches_numpy(tmp_path, n):
    rng = np.random.default_rng(100 + n)
    mem = random_members(rng, [4, 3, 5], n)
    m = build(tmp_path, mem, "--quantiles", "8")
    v = mem.astype(float)
    tol = 1e-5 * np.abs(v).max()
    np.testing.assert_allclose(m.array("mean"), v.mean(0), rtol=0, atol=tol)
    np.testing.assert_allclose(m.array("stddev"), v.std(0, ddof=1), rtol=0, atol=tol)
    np.testing.assert_allclose(m.array("min"), v.min(0), rtol=0, atol=0)
    np.testing.assert_allclose(m.array("max"), v.max(0), rtol=0, atol=0)
    b = np.moveaxis(np.quantile(v, np.arange(9) / 8, axis=0), 0, -1)
    np.testing.assert_allclose(m.array("quantiles"), b, rtol=0, atol=tol)
    iqr = np.moveaxis(np.quantile(v, [0.25, 0.75], axis=0), 0, -1)
    np.testing.assert_allclose(m.array("iqr"), iqr, rtol=0, atol=tol)
    assert m.quantile_count == 8 and m.samples_per_voxel == n and m.downsample == 0
    assert m.grid.origin == [0.5, -1.0, 2.0] and m.grid.spacing == [1.0, 0.5, 2.0]


@pytest.mark.parametrize("bandwidth", ["silverman", "scott", "0.3"])
def test_kde_build_matches_numpy(tmp_path, bandwidth):
    rng = np.random.default_rng(7)
    n = 9
    mem = random_members(rng, [3, 3, 2], n)
    m = build(tmp_path, mem, "--quantiles", "4", "--density", "kde", "--bandwidth", bandwidth)
    s = mem.astype(float).reshape(n, -1).T  # (V, n)
    sd = s.std(1, ddof=1)
    q25, q75 = np.quantile(s, [0.25, 0.75], axis=1)
    iqr = q75 - q25
    if bandwidth == "silverman":
        h = 0.9 * np.where(iqr > 0, np.minimum(sd, iqr / 1.34), sd) * n ** -0.2
    elif bandwidth == "scott":
        h = sd * n ** -0.2
    else:
        h = np.full(len(s), 0.3)
    eps = 1 / (2 * n)
    probs = np.array([eps, 0.25, 0.5, 0.75, 1 - eps])
    const = s.max(1) == s.min(1)
    hh = np.where(const, 1.0, h)
    b = kde_quantiles(s, probs, hh)
    b = np.where(const[:, None], s[:, :1], b)
    tol = 1e-5 * np.abs(s).max()
    got = m.array("quantiles").reshape(-1, 5)
    np.testing.assert_allclose(got, b, rtol=0, atol=tol)
    np.testing.assert_allclose(m.array("iqr").reshape(-1, 2), b[:, [1, 3]], rtol=0, atol=tol)


def test_downsample_bricks_and_geometry(tmp_path):
    rng = np.random.default_rng(9)
    field = rng.normal(size=(5, 6, 7)).astype(np.float32)  # X=7, Y=6, Z=5
    origin, spacing = [1.0, 2.0, -1.0], [0.5, 0.25, 1.0]
    p = tmp_path / "f.vti"
    udvr.write_field(str(p), udvr.Field(field, origin, spacing))
    out = tmp_path / "model.vti"
    # Empirical named: --downsample's default is kde (docs/experiments.md, downsample-estimators).
    refcase.run_udvr("build", p, "--downsample", "2", "--gmm", "0", "--density", "empirical",
                     "-o", out)
    m = udvr.read_model(str(out))
    k = 2
    assert m.grid.dims == [3, 3, 2]
    np.testing.assert_allclose(m.grid.spacing, np.array(spacing) * k)
    np.testing.assert_allclose(m.grid.origin, np.array(origin) + (k - 1) / 2 * np.array(spacing))
    np.testing.assert_allclose(m.bounds, [1.0, 4.0, 2.0, 3.25, -1.0, 3.0])
    assert m.downsample == 2 and m.samples_per_voxel == 8
    assert m.full_res_min_spacing == pytest.approx(0.25)
    bricks = field[:4, :6, :6].reshape(2, 2, 3, 2, 3, 2).transpose(0, 2, 4, 1, 3, 5).reshape(
        2, 3, 3, 8).astype(float)
    np.testing.assert_allclose(m.array("mean"), bricks.mean(-1), atol=1e-5)
    np.testing.assert_allclose(m.array("stddev"), bricks.std(-1, ddof=1), atol=1e-5)
    b = np.moveaxis(np.quantile(bricks, np.arange(9) / 8, axis=-1), 0, -1)
    np.testing.assert_allclose(m.array("quantiles"), b, atol=1e-5)
