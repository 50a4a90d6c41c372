// expectedTf2UniformExact (the `uniform` model's 2D TF classification) against closed forms
// and against its own refinement. Its Monte Carlo check is python/tests/test_reference2d_cli.py.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <random>
#include <vector>

#include "udvr/classify/expected_tf2_uniform_test_util.h"

namespace udvr {
namespace {
using testing::Bilinear;
using testing::Case;
using testing::randomCase;
using testing::Raster;

void exact(const Tf2Raster<double>& r, const Case& c, double out[4], int xCells = 384,
           double kTol = 1e-11) {
    Tf2UniformExactOptions o;
    o.xCells = xCells;
    o.kTol = kTol;
    expectedTf2UniformExact(r, c.cx, c.cy, c.d.data(), static_cast<int>(c.d.size()), 1e-12, o, out);
}

// α and c linear in (x, y) inside the domain, so α·c is quadratic:
// E[α·c] = α(μ)c(μ) + q_α q_c var X + (q_α s_c + s_α q_c) cov(X, G) + s_α s_c var G, with
// α = p + q x + s y, var X = Σa²/3, cov = Σab/3, var G = Σb²/3. Every direction's a, b and sign
// enters; the support stays inside the domain.
TEST(Tf2UniformExact, QuadraticTfIsClosedForm) {
    // Dyadic, so that the float raster holds the linear functions exactly.
    const double P[4] = {0.25, 0.625, 0.1875, 0.5}, Q[4] = {0.0625, -0.125, 0.03125, 0.09375},
                 S[4] = {-0.0625, 0.015625, 0.09375, 0.078125};
    const Raster ras(9, 9, -3, 3, -4, 4, [&](double x, double y, double v[4]) {
        for (int ch = 0; ch < 4; ++ch) v[ch] = P[ch] + Q[ch] * x + S[ch] * y;
    });
    std::mt19937_64 g(7);
    const int shapes[][2] = {{8, 24}, {8, 0}, {4, 6}, {1, 0}, {1, 24}, {0, 5}, {2, 1}};
    double worst = 0.0;
    for (const auto& sh : shapes)
        for (int rep = 0; rep < 4; ++rep) {
            const Case c = randomCase(g, sh[0], sh[1], 0.3, 0.2, 0.05);
            double vx = 0, cov = 0, vg = 0;
            for (const BoxDirection2& d : c.d)
                vx += d.a * d.a / 3, cov += d.a * d.b / 3, vg += d.b * d.b / 3;
            double got[4];
            exact(ras.r, c, got);
            const double am = P[3] + Q[3] * c.cx + S[3] * c.cy;
            EXPECT_NEAR(got[3], am, 1e-9);
            for (int ch = 0; ch < 3; ++ch) {
                const double cm = P[ch] + Q[ch] * c.cx + S[ch] * c.cy;
                const double want = am * cm + Q[3] * Q[ch] * vx +
                                    (Q[3] * S[ch] + S[3] * Q[ch]) * cov + S[3] * S[ch] * vg;
                worst = std::max(worst, std::abs(got[ch] - want));
                EXPECT_NEAR(got[ch], want, 1e-8) << sh[0] << " corners, " << sh[1] << " y-only";
            }
        }
    std::printf("quadratic TF2: worst |ΔE[α·c]| %.2e\n", worst);
}

// E[f(V)] for V = c + Σ_{k<n} t_k h_k (n ≤ 2 boxes, t ~ U[−1, 1]) and f piecewise linear with
// knots `knots`: the density is piecewise linear, so Simpson between all knots is exact.
double boxExpectation(double c, std::vector<double> h, const std::function<double(double)>& f,
                      std::vector<double> knots) {
    for (double& v : h) v = std::abs(v);
    const auto density = [&](double v) {
        v -= c;
        if (h.size() == 1) return std::abs(v) <= h[0] ? 0.5 / h[0] : 0.0;
        // Two boxes: the overlap of [v − h1, v + h1] with [−h0, h0], over 4 h0 h1.
        const double lo = std::max(v - h[1], -h[0]), hi = std::min(v + h[1], h[0]);
        return std::max(hi - lo, 0.0) / (4 * h[0] * h[1]);
    };
    double tot = 0;
    for (double v : h) tot += v;
    knots.push_back(c - tot), knots.push_back(c + tot);
    if (h.size() == 2)
        for (double s : {-1.0, 1.0})
            for (double t : {-1.0, 1.0}) knots.push_back(c + s * h[0] + t * h[1]);
    std::sort(knots.begin(), knots.end());
    double e = 0;
    for (std::size_t k = 0; k + 1 < knots.size(); ++k) {
        const double a = std::max(knots[k], c - tot), b = std::min(knots[k + 1], c + tot);
        if (!(b > a)) continue;
        const auto g = [&](double v) { return density(v) * f(v); };
        const double m = 0.5 * (a + b), e1 = 1e-13 * (b - a);
        // One-sided limits at the ends (the density jumps at a box's ends).
        e += (b - a) / 6 * (g(a + e1) + 4 * g(m) + g(b - e1));
    }
    return e;
}

// One corner with b = 0 and two y-only directions: X and G independent, and a separable TF2
// α = f(x)·g(y) (f, g piecewise linear, clamped; c constant) gives E[α] = E[f(X)]·E[g(G)].
TEST(Tf2UniformExact, IndependentCornerIsAProduct) {
    std::mt19937_64 gen(11);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int rep = 0; rep < 10; ++rep) {
        const int W = 6, H = 5;
        std::vector<double> fx(W), gy(H);
        for (double& v : fx) v = std::floor(16 * u(gen)) / 16;  // f·g exact in float
        for (double& v : gy) v = std::floor(16 * u(gen)) / 16;
        const double x0 = -1, x1 = 1, y0 = -0.8, y1 = 0.9, col[3] = {0.2, 0.5, 0.9};
        const auto lerp = [](const std::vector<double>& t, double lo, double hi, double v) {
            const double last = static_cast<double>(t.size() - 1);
            double s = std::clamp((v - lo) / (hi - lo) * last, 0.0, last);
            const int i = std::min(static_cast<int>(s), static_cast<int>(t.size()) - 2);
            s -= i;
            return t[i] + s * (t[i + 1] - t[i]);
        };
        const Raster ras(W, H, x0, x1, y0, y1, [&](double x, double y, double v[4]) {
            for (int ch = 0; ch < 3; ++ch) v[ch] = col[ch];
            v[3] = lerp(fx, x0, x1, x) * lerp(gy, y0, y1, y);
        });
        Case c;
        c.cx = 1.6 * u(gen) - 0.8, c.cy = 1.2 * u(gen) - 0.6;
        const double a = 0.1 + 0.6 * u(gen);
        c.d = {{0.0, 0.1 + 0.4 * u(gen)}, {a, 0.0}, {0.0, -0.05 - 0.3 * u(gen)}};
        std::vector<double> kx, ky;
        for (int i = 0; i < W; ++i) kx.push_back(x0 + i * (x1 - x0) / (W - 1));
        for (int j = 0; j < H; ++j) ky.push_back(y0 + j * (y1 - y0) / (H - 1));
        const double ex = boxExpectation(
            c.cx, {a}, [&](double v) { return lerp(fx, x0, x1, v); }, kx);
        const double eg = boxExpectation(
            c.cy, {c.d[0].b, c.d[2].b}, [&](double v) { return lerp(gy, y0, y1, v); }, ky);
        double got[4];
        exact(ras.r, c, got);
        EXPECT_NEAR(got[3], ex * eg, 1e-9);
        for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(got[ch], col[ch] * got[3], 1e-7);
    }
}

// The defaults' result against a finer one (node grids 2× finer, the series run to 1e−13):
// within 1e−7 (a tenth of the stated bound, 1e−6), on random 7×5 rasters and 8 corners + 24 y-only
// directions, as in the pytest's models; also 8 corners alone (the largest binning error), and one
// or two corners with little or no y-only spread (the longest series).
TEST(Tf2UniformExact, RefinementChangesLessThanTheBound) {
    std::mt19937_64 gen(5);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    double worst = 0.0;
    const int shapes[][2] = {{8, 24}, {8, 0}, {4, 8}, {1, 0}, {1, 2}, {2, 0}};
    for (const auto& sh : shapes)
        for (int rep = 0; rep < 3; ++rep) {
            std::vector<double> v(7 * 5 * 4);
            for (double& x : v) x = u(gen);
            const Raster ras(7, 5, -1, 1, -0.5, 1.0, [&](double x, double y, double out[4]) {
                const int i = static_cast<int>(std::lround((x + 1) * 3)),
                          j = static_cast<int>(std::lround((y + 0.5) * 4 / 1.5));
                for (int ch = 0; ch < 4; ++ch) out[ch] = v[(j * 7 + i) * 4 + ch];
            });
            Case c = randomCase(gen, sh[0], sh[1], 0.15, 0.3, 0.08);
            c.cy += 0.5;
            double a[4], b[4];
            exact(ras.r, c, a);
            exact(ras.r, c, b, 768, 1e-13);
            for (int ch = 0; ch < 4; ++ch) {
                worst = std::max(worst, std::abs(a[ch] - b[ch]));
                EXPECT_NEAR(a[ch], b[ch], 1e-7) << sh[0] << " corners, " << sh[1] << " y-only";
            }
        }
    std::printf("refinement: worst change %.2e\n", worst);
}

// max over the channels of |exact − closed form|.
double bilinearError(const Raster& ras, const Bilinear& tf, const Case& c) {
    double got[4], want[4], worst = 0;
    exact(ras.r, c, got);
    tf.expectation(c, want);
    for (int ch = 0; ch < 4; ++ch) worst = std::max(worst, std::abs(got[ch] - want[ch]));
    return worst;
}

// A sample beside a voxel face: four corners of trilinear weight ~1e−3 (|a| = 0.003, narrower
// than the node spacing, ~0.005 and 0.01) with four wide ones, unit-order slopes b/a, and y-only
// directions. α and c bilinear in (x, y) with unit slopes in x (the raster holds them exactly),
// so α·c is a polynomial of degree ≤ 2 in x and in y and E[α·c] follows from the box spline's
// moments. Binning the narrow boxes by linear weights left 7.6e−6 here (their binned variance
// ≈ |a|·Δx/2, not a²/3: first order in Δx, which Richardson does not remove).
TEST(Tf2UniformExact, NarrowCornersBesideAFaceAreClosedForm) {
    const Bilinear tf{{0.25, -0.5, 0.125, 0.375},
                      {1.0, 0.75, -1.0, 1.0},
                      {0.125, -0.25, 0.0625, -0.1875},
                      {0.0625, 0.125, -0.03125, 0.09375}};
    const Raster ras(9, 13, -4, 4, -6, 6, tf);
    Case c;
    c.cx = 0.3125, c.cy = -0.21;
    c.d = {{0.003, 0.0021},  {0.0, 0.12},   {0.7, -0.56},   {0.63, 0.9},
           {-0.003, 0.0036}, {0.63, -0.47}, {0.0, -0.08},   {-0.63, 0.7},
           {0.003, -0.003},  {0.0, 0.05},   {0.003, 0.0012}};
    const double worst = bilinearError(ras, tf, c);
    EXPECT_LT(worst, 1e-8);
    std::printf("narrow corners beside a face: worst |ΔE| %.2e\n", worst);
}

// Corners tiny against |cx| (1e−9 at cx ≈ 1000: a few thousand ulps of cx): the widest corner's
// segment is integrated in coordinates relative to its node, so its length stays 2|a| to the
// last digit (as the difference of two cumulative integrals at cx ± |a| it was up to 4.9e−6
// off here); what is left is the series' tail (≤ 1e−11). A lone corner (a segment), one with
// y-only directions, and binned corners under it, inside a column strip and across a column
// (x = 1000); on a raster with dyadic columns and α, c bilinear, and on one whose columns are
// not dyadic (0.3 apart, so a column's position rounds) with α, c constant in x.
TEST(Tf2UniformExact, TinyCornersFarFromTheOriginKeepTheirDigits) {
    const Bilinear tf{{0.25, -0.5, 0.125, 0.375},
                      {0.125, 0.0625, -0.25, 0.125},
                      {0.125, -0.25, 0.0625, -0.1875},
                      {0.0625, 0.125, -0.03125, 0.09375},
                      1000.0};
    Bilinear flatInX = tf;
    for (int ch = 0; ch < 4; ++ch) flatInX.Q[ch] = flatInX.T[ch] = 0.0;
    const Raster dyadic(9, 9, 992, 1008, -4, 4, tf), tenths(9, 9, 998.8, 1001.2, -4, 4, flatInX);
    const std::vector<std::vector<BoxDirection2>> shapes = {
        {{1e-9, 0.3}},
        {{1e-9, 0.3}, {0.0, 0.2}, {0.0, -0.1}},
        {{4e-10, -0.2}, {1e-9, 0.3}, {-3e-10, 0.1}, {0.0, 0.2}},
        {{4e-10, -0.2}, {1e-9, 0.3}, {-3e-10, 0.1}}};
    double worst = 0;
    const auto check = [&](const Raster& ras, const Bilinear& f, double cx, const char* what) {
        for (const auto& d : shapes) {
            const double e = bilinearError(ras, f, Case{cx, 0.37, d});
            worst = std::max(worst, e);
            EXPECT_LT(e, 1e-10) << "cx " << cx << ", " << d.size() << " directions, " << what;
        }
    };
    for (const double cx : {1000.0 + 1.0 / 3, 1001.0, 999.0 + 1e-10, 1000.0 + 3e-10, 1000.0})
        check(dyadic, tf, cx, "dyadic columns");
    for (int i = 1; i < 8; ++i)  // across each inner column, as the code places it
        check(tenths, flatInX, tenths.r.x0 + i / tenths.r.invDx + 3e-10, "columns 0.3 apart");
    std::printf("tiny corners at cx ≈ 1000: worst |ΔE| %.2e\n", worst);
}

// Non-finite data (a NaN voxel) gives a finite lookup, as the other 2D kernels, not a crash.
TEST(Tf2UniformExact, NonFiniteDataIsALookup) {
    const Raster ras(3, 3, 0, 1, 0, 1, [](double x, double y, double v[4]) {
        v[0] = v[1] = v[2] = 0.5, v[3] = 0.25 + 0.5 * x * y;
    });
    Case c;
    c.cx = std::nan(""), c.cy = 0.5;
    c.d = {{0.1, 0.2}, {0.2, -0.1}, {0.0, 0.1}};
    // The TF2 at (cx, cy), premultiplied; NaN maps to the domain's origin column. α = 0.25 +
    // 0.5·x·y is bilinear, so the raster holds it exactly.
    const auto expectLookup = [&](double x, double y) {
        double got[4];
        exact(ras.r, c, got);
        const double a = 0.25 + 0.5 * x * y;
        for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(got[ch], 0.5 * a, 1e-12) << ch;
        EXPECT_NEAR(got[3], a, 1e-12);
    };
    expectLookup(0.0, 0.5);
    c.cx = 0.5, c.d[1].b = std::numeric_limits<double>::infinity();
    expectLookup(0.5, 0.5);
    // A NaN or infinite width a, on a corner or on the y-only direction: the same lookup (a NaN
    // a was once taken for a y-only direction and gave E[α] = 0.3717 here, not 0.375).
    for (const int i : {0, 2})
        for (const double bad : {std::nan(""), std::numeric_limits<double>::infinity()}) {
            c.d = {{0.1, 0.2}, {0.2, -0.1}, {0.0, 0.1}};
            c.d[i].a = bad;
            expectLookup(0.5, 0.5);
        }
}

// The coarse settings (kUniform2DFast: the same evaluation on coarser grids, fewer series
// terms; the fast `uniform`'s fallback where its tables do not apply) against the converged
// one (`uniform-exact`) over random rough rasters (W×H from 10×7 to
// 66×42 over [−1, 1]², every point's (c, α) random) and random box splines (8 corners, 0–23
// G-only directions): issue 33 asks ≤ 1e−3; measured 1.8e−4 (2026-12-02).
TEST(Tf2UniformExact, FastSettingsWithin1e3OfConverged) {
    std::mt19937_64 g(35);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    double worst = 0.0;
    for (int raster = 0; raster < 8; ++raster) {
        const Raster ras(10 + raster * 8, 7 + raster * 5, -1.0, 1.0, -1.0, 1.0,
                         [&](double, double, double v[4]) {
                             for (int ch = 0; ch < 4; ++ch) v[ch] = u(g);
                         });
        for (int k = 0; k < 10; ++k) {
            const Case c = randomCase(g, 8, static_cast<int>(u(g) * 24), 0.25, 0.6, 0.15);
            double got[4], want[4];
            Tf2UniformExactOptions coarse = kUniform2DFast, converged;
            expectedTf2UniformExact(ras.r, c.cx, c.cy, c.d.data(), static_cast<int>(c.d.size()),
                                    0.0, coarse, got);
            expectedTf2UniformExact(ras.r, c.cx, c.cy, c.d.data(), static_cast<int>(c.d.size()),
                                    0.0, converged, want);
            for (int ch = 0; ch < 4; ++ch) worst = std::max(worst, std::abs(got[ch] - want[ch]));
        }
    }
    std::printf("uniform (kUniform2DFast) vs uniform-exact: max |dE| %.3g\n", worst);
    EXPECT_LE(worst, 1e-3);
    EXPECT_GT(worst, 0.0);  // the settings differ (else this checks nothing)
}

}  // namespace
}  // namespace udvr
