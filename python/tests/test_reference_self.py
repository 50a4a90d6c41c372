"""The reference (reference.py) against still more direct computations, so that a disagreement
with udvr points at udvr: adaptive quadrature, Monte Carlo, closed forms, VTK camera facts."""
import math

import numpy as np
from scipy import integrate

import reference as ref

TF = ref.TF([0, 0.3, 0.3, 1.0], [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0]],
            [0.1, 0.5, 0.5, 0.9], [0.2, 0.8, 0.3, 1.0])


def quad(f, a, b):
    pts = [p for p in TF.breaks if a < p < b]
    return np.array([integrate.quad(lambda x: f(x)[c], a, b, points=pts or None, limit=400,
                                    epsabs=1e-13)[0] for c in range(4)])


def test_tf_steps_are_right_continuous_and_clamped():
    np.testing.assert_allclose(TF(np.array(0.3)), [0, 0, 0.5, 0.5])  # colour: later point from x on
    t = 0.2 / 0.7  # colour between (0,0,1) at 0.3 and (1,1,0) at 1.0; opacity steps to 0.3
    np.testing.assert_allclose(TF(np.array(0.5)), [0.3 * t, 0.3 * t, 0.3 * (1 - t), 0.3])
    np.testing.assert_allclose(TF(np.array(-7.0)), [0.2, 0, 0, 0.2])
    np.testing.assert_allclose(TF(np.array(9.0)), [1, 1, 0, 1])
    # Just left of the step: the earlier point's segment.
    np.testing.assert_allclose(TF(np.array(0.3 - 1e-12))[3], 0.2 + 0.6 * 0.2 / 0.4, atol=1e-9)


def test_interval_mean_is_exact():
    for a, b in [(-1, 0.2), (0.25, 0.55), (0.3, 0.3 + 1e-9), (0.95, 3)]:
        want = quad(lambda x: TF(np.array(x)), a, b) / (b - a)
        np.testing.assert_allclose(TF.interval_mean(np.array(a), np.array(b), 0.0), want,
                                   atol=1e-9)


def test_gaussian_closed_form_against_quadrature():
    for mu, s in [(0.4, 0.1), (0.5, 0.01), (2, 0.3), (-1, 0.5), (0.3, 1e-3)]:
        pdf = lambda x: math.exp(-0.5 * ((x - mu) / s) ** 2) / (s * math.sqrt(2 * math.pi))
        want = quad(lambda x: TF(np.array(x)) * pdf(x), mu - 12 * s, mu + 12 * s)
        np.testing.assert_allclose(TF.gaussian_expectation(np.array(mu), np.array(s)), want,
                                   atol=1e-10)


def test_uniform_sum_one_and_two_terms_closed_form():
    np.testing.assert_allclose(ref.uniform_sum_expectation(TF, 0.1, [0.5], 0.0),
                               TF.interval_mean(np.array(0.1), np.array(0.6), 0.0), atol=1e-12)
    a, b, s = 0.3, 0.1, 0.05  # trapezoid density
    dens = lambda y: max(0.0, min(y, a + b - y, b)) / (a * b)
    want = quad(lambda x: TF(np.array(x)) * dens(x - s), s, s + a + b)
    np.testing.assert_allclose(ref.uniform_sum_expectation(TF, s, [a, b], 0.0), want, atol=1e-10)


def test_uniform_sum_of_eight_against_monte_carlo():
    rng = np.random.default_rng(3)
    ws = rng.uniform(0, 0.2, 8)
    ws[3] = 1e-5
    got = ref.uniform_sum_expectation(TF, -0.1, ws, 0.0)
    n = 300_000
    x = -0.1 + (rng.random((n, 8)) * ws).sum(1)
    v = TF(x)
    se = v.std(0) / math.sqrt(n)
    assert np.all(np.abs(got - v.mean(0)) < 5 * se + 1e-12), (got, v.mean(0), se)


def test_default_camera_matches_vtk_orbit():
    b = [0, 2, 0, 2, 0, 2]
    cam = ref.default_camera(b, azimuth=90, elevation=0, zoom=1, view_angle=30)
    d = math.sqrt(3) / math.sin(math.radians(15))
    np.testing.assert_allclose(cam["position"], [1 + d, 1, 1], atol=1e-12)  # Azimuth +90: +x
    cam = ref.default_camera(b, azimuth=0, elevation=30, zoom=2, view_angle=30)
    np.testing.assert_allclose(cam["position"],
                               [1, 1 + d / 2 * 0.5, 1 + d / 2 * math.cos(math.radians(30))],
                               atol=1e-12)  # Elevation +30: camera above the x–z plane


def test_pixel_centres_top_left_first():
    cam = dict(position=[0, 0, 10], focal_point=[0, 0, 0], view_up=[0, 1, 0], view_angle=90)
    o, d = ref.camera_rays(cam, 4, 2)
    assert d[0, 0, 0] < 0 and d[0, 0, 1] > 0  # top-left pixel looks left and up
    assert d[1, 3, 0] > 0 and d[1, 3, 1] < 0
    # tan(45°) = 1: pixel centre x of column 0 of 4 at ndc −0.75, aspect 2 → −1.5.
    np.testing.assert_allclose(d[0, 0] / -d[0, 0, 2], [-1.5, 0.5, -1], atol=1e-12)
    o, d = ref.camera_rays(cam, 4, 2, parallel_scale=2.0)
    np.testing.assert_allclose(o[0, 0], [-3, 1, 10], atol=1e-12)
    np.testing.assert_allclose(d[0, 0], [0, 0, -1], atol=1e-12)


def test_beer_lambert_on_a_constant_field():
    """Constant α over a ray of length L, Δ | L: 1 − (1 − α)^(L/u); colour c times that."""
    mean = np.full((3, 3, 3), 0.5)
    m = ref.RefModel(mean, origin=(0, 0, 0), spacing=(1, 1, 1))
    tf = ref.TF([0], [[0.2, 0.4, 0.6]], [0], [0.3])
    cam = dict(position=[1, 1, 10], focal_point=[1, 1, 1], view_up=[0, 1, 0], view_angle=30)
    img = ref.render(m, "mean", tf, 3, 3, cam, parallel_scale=0.5, step=0.25, unit=1.0,
                     early_exit=1.0, background=(0, 0, 0))
    a = 1 - 0.7 ** 2.0
    np.testing.assert_allclose(img[1, 1], [0.2 * a, 0.4 * a, 0.6 * a, a], atol=1e-12)
