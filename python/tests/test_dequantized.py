"""`build --density dequantized` (issue 12.2) against an independent NumPy/SciPy computation:
each integer sample v is spread uniformly over [v − ½, v + ½] of its quantisation step, and the
boundaries are the exact quantiles of that mixture (a histogram density on unit cells), with
F⁻¹(p) = inf{x : F(x) ≥ p}. Checked on bricks of a uint8 field and on an int16 ensemble, through
the CLI and the Python API; the moments stay those of the samples; a float input is refused
with one line."""
import numpy as np
import pytest
from scipy import stats

from conftest import assert_one_line_error, listing, run_udvr, write_nrrd
import refcase

udvr = pytest.importorskip("udvr")

LEVELS = np.arange(9) / 8


def mixture_quantiles(samples, probs, step=1.0):
    """F⁻¹(probs) of the samples (integers in units of `step`) each spread over its step: the
    histogram of unit cells [v − step/2, v + step/2] between min and max, inverted as
    inf{x : F(x) ≥ p}, with F⁻¹(0) = min − step/2."""
    k = np.rint(np.asarray(samples, float) / step).astype(int)
    counts = np.bincount(k - k.min())
    edges = (np.arange(len(counts) + 1) + k.min() - 0.5) * step
    cdf = np.concatenate([[0.0], np.cumsum(counts) / len(k)])
    out = []
    for p in probs:
        if p <= 0:
            out.append(edges[0])
            continue
        i = min(int(np.searchsorted(cdf, p - 1e-15, side="left")), len(cdf) - 1)
        out.append(edges[i - 1] + (p - cdf[i - 1]) / (cdf[i] - cdf[i - 1]) * step)
    return np.array(out), counts, edges, cdf


def check_against_scipy(samples, probs, got):
    """The same quantiles from scipy.stats.rv_histogram, where F is not flat at p (there SciPy's
    interpolation may pick any point of the flat piece)."""
    ref, counts, edges, cdf = mixture_quantiles(samples, probs)
    hist = stats.rv_histogram((counts, edges), density=False)
    for p, g in zip(probs, got):
        if 0 < p < 1 and not np.any(np.isclose(cdf, p, rtol=0, atol=1e-12)):
            assert abs(hist.ppf(p) - g) <= 1e-6 * max(1.0, abs(g)), (p, g, hist.ppf(p))  # float32
    return ref


def tied_integers(rng, shape, hi=40):
    """Integer samples with many ties and gaps: mostly 0, a few clusters, some constant bricks."""
    v = np.where(rng.random(shape) < 0.6, 0, rng.choice([3, 4, 4, 17, 18, hi], size=shape))
    return v


@pytest.fixture(scope="module")
def bricks(tmp_path_factory):
    """A 8×6×4 uint8 field (x fastest) and its model in 2³ bricks, dequantized."""
    tmp = tmp_path_factory.mktemp("dequant")
    rng = np.random.default_rng(12)
    field = tied_integers(rng, (4, 6, 8)).astype(np.uint8)  # (z, y, x)
    field[:2, :2, :2] = 9  # one constant brick
    path = write_nrrd(tmp / "f.nrrd", field.ravel().tolist(), (8, 6, 4), type_name="uint8",
                      fmt="<B")
    out = tmp / "m.vti"
    refcase.run_udvr("build", path, "--downsample", "2", "--density", "dequantized", "--gmm", "1",
                     "-o", out)
    return field, path, udvr.read_model(str(out))


def brick_samples(field, k=2):
    """(Z', Y', X', k³) samples of each k³ brick of a (Z, Y, X) field."""
    Z, Y, X = (s // k for s in field.shape)
    b = field[:Z * k, :Y * k, :X * k].reshape(Z, k, Y, k, X, k).transpose(0, 2, 4, 1, 3, 5)
    return b.reshape(Z, Y, X, k ** 3)


def test_brick_boundaries_match_numpy_and_scipy(bricks):
    field, _, m = bricks
    s = brick_samples(field.astype(float))
    q, iqr = m.array("quantiles"), m.array("iqr")
    assert q.shape == s.shape[:3] + (9,)
    for idx in np.ndindex(s.shape[:3]):
        got = q[idx].astype(float)
        ref = check_against_scipy(s[idx], LEVELS, got)
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-5)
        iqr_ref, *_ = mixture_quantiles(s[idx], [0.25, 0.75])
        np.testing.assert_allclose(iqr[idx], iqr_ref, rtol=0, atol=1e-5)
    # The constant brick of 9s is U[8.5, 9.5], not a point mass.
    np.testing.assert_allclose(q[0, 0, 0], 8.5 + LEVELS, rtol=0, atol=1e-6)
    assert m.density == "dequantized" and m.bandwidth == 1.0


def test_moments_are_the_samples_as_for_empirical(bricks, tmp_path):
    field, path, m = bricks
    out = tmp_path / "e.vti"
    refcase.run_udvr("build", path, "--downsample", "2", "--gmm", "1", "--density", "empirical",
                     "-o", out)
    e = udvr.read_model(str(out))
    for name in ("mean", "stddev", "min", "max", "gmm"):
        assert np.array_equal(m.array(name), e.array(name)), name
    assert not np.array_equal(m.array("quantiles"), e.array("quantiles"))


def test_python_build_equals_the_cli(bricks):
    field, path, m = bricks
    from_array = udvr.build(field, downsample=2, density="dequantized", gmm=1, progress=False)
    from_file = udvr.build(str(path), downsample=2, density="dequantized", gmm=1, progress=False)
    for got in (from_array, from_file):
        assert np.array_equal(got.array("quantiles"), m.array("quantiles"))
        assert np.array_equal(got.array("iqr"), m.array("iqr"))
        assert got.density == "dequantized"


def test_int16_ensemble_members_match_numpy(tmp_path):
    rng = np.random.default_rng(3)
    members = (tied_integers(rng, (6, 3, 2, 4), hi=300) - 100).astype(np.int16)  # (n, z, y, x)
    paths = [write_nrrd(tmp_path / f"m{i}.nrrd", mem.ravel().tolist(), (4, 2, 3),
                        type_name="int16", fmt="<h") for i, mem in enumerate(members)]
    out = tmp_path / "m.vti"
    refcase.run_udvr("build", *paths, "--density", "dequantized", "--quantiles", "4", "--gmm",
                     "0", "-o", out)
    q = udvr.read_model(str(out)).array("quantiles")
    s = np.moveaxis(members.astype(float), 0, -1)
    for idx in np.ndindex(s.shape[:3]):
        got = q[idx].astype(float)
        ref = check_against_scipy(s[idx], np.arange(5) / 4, got)
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-4)


def test_float_input_is_a_one_line_error(tmp_path):
    f = tmp_path / "f.vti"
    udvr.write_field(str(f), udvr.Field(np.zeros((4, 4, 4), np.float32)))
    before = listing(tmp_path)
    r = run_udvr("build", f, "--downsample", "2", "--density", "dequantized", "-o",
                 tmp_path / "m.vti")
    assert_one_line_error(r, "dequantized", "float32", "integer-typed")
    assert listing(tmp_path) == before  # no model, no temporary
    with pytest.raises(ValueError, match="integer-typed"):
        udvr.build(np.zeros((4, 4, 4), np.float32), downsample=2, density="dequantized",
                   progress=False)
    r = run_udvr("build", f, "--downsample", "2", "--density", "histogram", "-o",
                 tmp_path / "m.vti")
    assert_one_line_error(r, "empirical, kde or dequantized")
