"""The Python API against independent NumPy/SciPy computations."""
import numpy as np
import pytest

udvr = pytest.importorskip("udvr")


def tangle_numpy(n):
    t = np.linspace(-2.5, 2.5, n)
    g = t**4 - 5 * t**2
    return g[:, None, None] + g[None, :, None] + g[None, None, :] + 11.8


def test_generate_tangle_matches_numpy():
    f = udvr.generate("tangle", [33, 33, 33])
    np.testing.assert_allclose(f.values, tangle_numpy(33), rtol=0, atol=2e-5)
    assert f.grid.dims == [33, 33, 33]
    assert f.grid.spacing[0] == pytest.approx(5 / 32)


def test_perturb_is_seeded_and_has_the_documented_moments():
    truth = np.zeros((30, 30, 30), dtype=np.float32)
    truth[0, 0, 0] = 10.0  # value range R = 10
    f = udvr.Field(truth)
    a = udvr.perturb(f, members=6, seed=3).values
    b = udvr.perturb(f, members=6, seed=3).values
    np.testing.assert_array_equal(a, b)
    noise = a.reshape(6, -1)[:, 1:].ravel()  # voxels whose truth is 0
    # 80 % N(0, 0.2^2) + 20 % N(2, 0.4^2): mean 0.4, variance 0.704 (units of R = 10).
    se = np.sqrt(0.704 / noise.size)
    assert abs(noise.mean() - 0.4) < 5 * se
    assert abs(noise.var() - 0.704) < 0.015
    assert abs((noise > 1.0).mean() - 0.2) < 0.005


def test_bad_input_raises_value_error():
    with pytest.raises(ValueError):
        udvr.generate("torus", [8, 8, 8])
    with pytest.raises(ValueError):
        udvr.perturb(udvr.generate("tangle", [8, 8, 8]), members=1)
