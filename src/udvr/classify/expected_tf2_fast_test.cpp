// The fast 2D gaussian and uniform (Tf2BlurTables) against their exact evaluations
// (expectedTf2Gaussian, expectedTf2UniformExact) over random rough rasters, distributions and
// points (issue 33 asks max |ΔE| ≤ 1e−3; measured: gaussian 8.1e−5 (9.8e−5 over lanes; share
// 0.8, radius 4.0 since 2026-12-04, held to 3e−4),
// uniform 9.1e−4 at interior points, 1.6e−3 at voxel faces — docs/models.md).
#include "udvr/classify/expected_tf2_fast.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <memory>
#include <random>
#include <sstream>
#include <vector>

#include "udvr/classify/expected_tf2_gaussian.h"
#include "udvr/classify/expected_tf2_uniform_test_util.h"
#include "udvr/classify/transfer_function_2d_widget_json.h"

namespace udvr {
namespace {

// A W×H raster over [lo, hi]² of random (c, α) in [0, 1] at each point (the roughest case:
// every cell's slopes independent).
testing::Raster roughRaster(std::mt19937_64& g, int W, int H, double lo = 0.0, double hi = 1.0) {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    return testing::Raster(W, H, lo, hi, lo, hi, [&](double, double, double v[4]) {
        for (int ch = 0; ch < 4; ++ch) v[ch] = u(g);
    });
}

TEST(Tf2BlurTables, GaussianWithin1e3OfTheExactEvaluation) {
    std::mt19937_64 g(33);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    double worst = 0.0, sq = 0.0;
    int count = 0;
    for (int raster = 0; raster < 12; ++raster) {
        const int W = 6 + static_cast<int>(u(g) * 60), H = 5 + static_cast<int>(u(g) * 60);
        const testing::Raster r = roughRaster(g, W, H);
        const Tf2BlurTables tables(r.r);
        for (int k = 0; k < 25; ++k) {
            // σ from a tenth of a cell to beyond the raster, any correlation.
            const double sx = std::exp(std::log(0.1 / (W - 1)) + u(g) * std::log(20.0 * W)),
                         sy = std::exp(std::log(0.1 / (H - 1)) + u(g) * std::log(20.0 * H));
            const double rho = 1.98 * u(g) - 0.99;
            const double mx = 1.4 * u(g) - 0.2, my = 1.4 * u(g) - 0.2;
            double got[4], want[4];
            tables.gaussian(r.r, mx, my, sx * sx, rho * sx * sy, sy * sy, got);
            expectedTf2Gaussian(r.r, mx, my, sx * sx, rho * sx * sy, sy * sy, want);
            for (int ch = 0; ch < 4; ++ch) {
                const double e = std::abs(got[ch] - want[ch]);
                worst = std::max(worst, e);
                sq += e * e;
                ++count;
            }
        }
    }
    std::printf("gaussian: max |dE| %.3g, RMS %.3g over %d values\n", worst, std::sqrt(sq / count),
                count);
    EXPECT_LE(worst, 3e-4);  // issue 33 asks 1e−3; a 3× margin
}

// The box spline's Edgeworth term makes its density negative in the far tail: with 12 equal boxes
// (none kept) and α > 0 only in a spot ~4.3σ out, beyond the support, the table sum is below 0
// (−5.2e−8 before the clamp; the exact evaluation −8e−10, 0 to its rounding; a probe of the 64³
// tangle gave −1.3e−5 where the exact value is +1.5e−6). E[α] ∈ [0, 1] and E[α·c] ∈ [0, E[α]]
// hold for every law, so boxSpline clamps to them: 0 here. (Written for the tables' form; by
// columns the same clamp holds the Edgeworth normal's tail.)
TEST(Tf2BlurTables, BoxSplineStaysInTheRangeOfAnExpectation) {
    const double r0 = 0.5 + 4.3 * std::sqrt(12.0 / 3.0) * 0.02 / std::sqrt(2.0);
    const testing::Raster r(97, 97, 0.0, 1.0, 0.0, 1.0, [&](double x, double y, double v[4]) {
        const bool spot = std::abs(x - r0) < 0.02 && std::abs(y - r0) < 0.02;
        v[0] = v[1] = v[2] = 1.0;
        v[3] = spot ? 1.0 : 0.0;
    });
    const Tf2BlurTables tables(r.r);
    std::vector<BoxDirection2> d;
    for (int i = 0; i < 12; ++i) {
        const double angle = 3.14159265358979 * i / 12.0;
        d.push_back({0.02 * std::cos(angle), 0.02 * std::sin(angle)});
    }
    double got[4], want[4];
    ASSERT_TRUE(tables.boxSpline(r.r, 0.5, 0.5, d.data(), 12, 0.0, got));
    Tf2UniformExactOptions opt;
    expectedTf2UniformExact(r.r, 0.5, 0.5, d.data(), 12, 0.0, opt, want);
    std::printf("far tail: E[alpha] %.3g (exact %.3g)\n", got[3], want[3]);
    EXPECT_GE(got[3], 0.0);
    EXPECT_LE(got[3], 1.0);
    for (int ch = 0; ch < 3; ++ch) {
        EXPECT_GE(got[ch], 0.0);
        EXPECT_LE(got[ch], got[3]);
    }
    EXPECT_LE(std::abs(got[3] - want[3]), 1e-3);
}

// The tables' own arrays are bounded: a TF2 over kMaxRasterPoints gets none, and three 700²
// TF2s' coefficients (3 × 63 MiB) cannot all fit under the process's 160 MiB cap. Where there
// are none, gaussian() and boxSpline() give the exact evaluations' values.
TEST(Tf2BlurTables, LargeTf2sGetNoTablesAndTakeTheExactEvaluation) {
    std::mt19937_64 g(37);
    const testing::Raster big = roughRaster(g, 1030, 1025);
    const Tf2BlurTables none(big.r);
    EXPECT_FALSE(none.available());
    double got[4], want[4];
    none.gaussian(big.r, 0.4, 0.6, 1e-4, 2e-5, 4e-4, got);
    expectedTf2Gaussian(big.r, 0.4, 0.6, 1e-4, 2e-5, 4e-4, want);
    for (int ch = 0; ch < 4; ++ch) EXPECT_EQ(got[ch], want[ch]);
    // 8 corners and a G-only direction: with tables this would take the columns.
    const BoxDirection2 d[9] = {{0.003, 0.001},  {0.002, -0.002}, {0.001, 0.003},
                                {0.004, 0.0},    {0.002, 0.002},  {0.001, -0.001},
                                {0.003, -0.003}, {0.002, 0.001},  {0.0, 0.004}};
    EXPECT_FALSE(none.boxSpline(big.r, 0.5, 0.5, d, 9, 0.0, got));
    expectedTf2UniformRefined(big.r, 0.5, 0.5, d, 9, 0.0, want);
    for (int ch = 0; ch < 4; ++ch) EXPECT_EQ(got[ch], want[ch]);

    const testing::Raster mid = roughRaster(g, 700, 700);
    std::vector<std::unique_ptr<Tf2BlurTables>> held;
    int available = 0;
    for (int k = 0; k < 3; ++k) {
        held.push_back(std::make_unique<Tf2BlurTables>(mid.r));
        available += held.back()->available();
    }
    EXPECT_LE(available, 2);
    const Tf2BlurTables& last = *held.back();
    if (!last.available()) {
        last.gaussian(mid.r, 0.3, 0.7, 0.01, 0.0, 0.02, got);
        expectedTf2Gaussian(mid.r, 0.3, 0.7, 0.01, 0.0, 0.02, want);
        for (int ch = 0; ch < 4; ++ch) EXPECT_EQ(got[ch], want[ch]);
    }
}

/// Lane l of the moments m (μx, μy, var x, cov, var y; float) of N((mx, my), σ and ρ).
void setLaneNormal(lanes::Vf m[5], int l, double mx, double my, double sx, double sy, double rho) {
    m[0][l] = static_cast<float>(mx);
    m[1][l] = static_cast<float>(my);
    m[2][l] = static_cast<float>(sx * sx);
    m[3][l] = static_cast<float>(rho * sx * sy);
    m[4][l] = static_cast<float>(sy * sy);
}

// The lane gaussian (float moments in, a row's points in float lanes) against the double one
// on the same moments, over the cases of GaussianWithin1e3OfTheExactEvaluation's kind (σ from a
// tenth of a cell to beyond the raster, any correlation, means off the raster too), and against
// the exact evaluation. Measured 2026-12-02 (AVX-512): 1.2e−7 and 3.4e−5; 2026-12-04 (share 0.8,
// radius 4.0, the y ladder's 2^¼ steps): 1.6e−7 and 9.8e−5; held to 2e−5, 3e−4 (issue 33 asks
// 1e−3).
TEST(Tf2BlurTables, LaneGaussianMatchesDouble) {
    using lanes::Vf;
    std::mt19937_64 g(34);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    double worst = 0.0, worstExact = 0.0;
    for (int raster = 0; raster < 12; ++raster) {
        const int W = 6 + static_cast<int>(u(g) * 60), H = 5 + static_cast<int>(u(g) * 60);
        const testing::Raster r = roughRaster(g, W, H);
        const Tf2BlurTables tables(r.r);
        for (int batch = 0; batch < 4; ++batch) {
            Vf m[5];
            for (int l = 0; l < lanes::kWidth; ++l) {
                const double sx = std::exp(std::log(0.1 / (W - 1)) + u(g) * std::log(20.0 * W)),
                             sy = std::exp(std::log(0.1 / (H - 1)) + u(g) * std::log(20.0 * H));
                const double rho = 1.98 * u(g) - 0.99;
                const double mx = 1.4 * u(g) - 0.2, my = 1.4 * u(g) - 0.2;
                setLaneNormal(m, l, mx, my, sx, sy, rho);
            }
            const lanes::Mask live = lanes::fromBits(lanes::kAllBits & ~1u);  // lane 0 dead
            Vf got[4] = {Vf{} + 7.0f, Vf{} + 7.0f, Vf{} + 7.0f, Vf{} + 7.0f};
            tables.gaussian(r.r, m, live, got);
            for (int ch = 0; ch < 4; ++ch) EXPECT_EQ(got[ch][0], 7.0f);  // dead: untouched
            for (int l = 1; l < lanes::kWidth; ++l) {
                double want[4], ref[4];
                tables.gaussian(r.r, m[0][l], m[1][l], m[2][l], m[3][l], m[4][l], want);
                expectedTf2Gaussian(r.r, m[0][l], m[1][l], m[2][l], m[3][l], m[4][l], ref);
                for (int ch = 0; ch < 4; ++ch) {
                    worst = std::max(worst, std::abs(got[ch][l] - want[ch]));
                    worstExact = std::max(worstExact, std::abs(got[ch][l] - ref[ch]));
                }
            }
        }
    }
    std::printf("lane gaussian: max |dE| %.3g against the double tables, %.3g against exact\n",
                worst, worstExact);
    EXPECT_LE(worst, 2e-5);
    EXPECT_LE(worstExact, 3e-4);
}

// The lane gaussian takes 0 where the rectangle m ± 5σ meets only cells with α = 0 (a TF2
// transparent for x < 0.6, random beyond): the exact value there is at most 4Φ(−5) = 1.1e−6.
// Normals whose rectangle reaches the opaque part keep the table sum, within 3e−4 of the exact
// evaluation as in LaneGaussianMatchesDouble.
TEST(Tf2BlurTables, LaneGaussianTakesZeroWhereItsRectangleIsTransparent) {
    using lanes::Vf;
    std::mt19937_64 g(35);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const testing::Raster r(41, 33, 0.0, 1.0, 0.0, 1.0, [&](double x, double, double v[4]) {
        for (int ch = 0; ch < 3; ++ch) v[ch] = u(g);
        v[3] = x > 0.6 ? u(g) : 0.0;
    });
    const Tf2BlurTables tables(r.r);
    int zeros = 0, sums = 0;
    double worstZero = 0.0, worstSum = 0.0;
    for (int batch = 0; batch < 40; ++batch) {
        Vf m[5];
        for (int l = 0; l < lanes::kWidth; ++l) {
            const double sx = 0.005 + 0.1 * u(g), sy = 0.02 + 2.0 * u(g);
            const double rho = 1.8 * u(g) - 0.9;
            const double mx = 0.6 * u(g) - 0.1, my = 1.4 * u(g) - 0.2;
            setLaneNormal(m, l, mx, my, sx, sy, rho);
        }
        Vf got[4];
        tables.gaussian(r.r, m, lanes::allTrue<Vf>(), got);
        for (int l = 0; l < lanes::kWidth; ++l) {
            double want[4];
            expectedTf2Gaussian(r.r, m[0][l], m[1][l], m[2][l], m[3][l], m[4][l], want);
            // The rectangle's cells lie left of x = 0.6's cell (raster cells of 1/40).
            const bool transparent = (m[0][l] + 5.0 * std::sqrt(m[2][l])) * 40.0 < 23.0;
            double e = 0.0;
            for (int ch = 0; ch < 4; ++ch) {
                e = std::max(e, std::abs(got[ch][l] - want[ch]));
                if (transparent) {
                    EXPECT_EQ(got[ch][l], 0.0f);
                }
            }
            if (transparent) {
                ++zeros;
                worstZero = std::max(worstZero, e);
            } else {
                ++sums;
                worstSum = std::max(worstSum, e);
            }
        }
    }
    std::printf("gaussian, transparent rectangles: %d at 0 (max |dE| %.3g), %d sums (%.3g)\n",
                zeros, worstZero, sums, worstSum);
    EXPECT_GT(zeros, 40);
    EXPECT_GT(sums, 40);
    EXPECT_LE(worstZero, 1.2e-6);
    EXPECT_LE(worstSum, 3e-4);
}

/// Worst |ΔE| of boxSpline against expectedTf2UniformExact (converged) over `cases` box splines
/// drawn by `draw` on the raster `r`; `fallbacks` counts those that took the exact evaluation
/// at the coarse kUniform2DFast settings (no table applies).
template <class Draw>
double boxSplineWorst(const Tf2Raster<double>& r, int cases, Draw draw, int& fallbacks,
                      int& count) {
    const Tf2BlurTables tables(r);
    double worst = 0.0;
    for (int k = 0; k < cases; ++k) {
        const testing::Case c = draw();
        double got[4], want[4];
        const int n = static_cast<int>(c.d.size());
        if (!tables.boxSpline(r, c.cx, c.cy, c.d.data(), n, 0.0, got)) ++fallbacks;
        Tf2UniformExactOptions opt;
        expectedTf2UniformExact(r, c.cx, c.cy, c.d.data(), static_cast<int>(c.d.size()), 0.0, opt,
                                want);
        for (int ch = 0; ch < 4; ++ch) worst = std::max(worst, std::abs(got[ch] - want[ch]));
        ++count;
    }
    return worst;
}

/// The widget TF2 data/tf2/tangle.json (256²); width 0 where the file is missing.
TransferFunction2D tangleTf2() {
    std::ifstream in(UDVR_FUZZ_REGRESSIONS_DIR "/../../data/tf2/tangle.json");
    if (!in) return {};
    std::stringstream text;
    text << in.rdbuf();
    return transferFunction2DFromWidgets(text.str(), "tangle.json");
}

/// The raster of `tf` (which must outlive it).
Tf2Raster<double> rasterOf(const TransferFunction2D& tf) {
    Tf2Raster<double> r;
    r.width = tf.width, r.height = tf.height, r.x0 = tf.x0, r.y0 = tf.y0;
    r.invDx = (tf.width - 1) / (tf.x1 - tf.x0), r.invDy = (tf.height - 1) / (tf.y1 - tf.y0);
    r.rgba = tf.rgba.data();
    return r;
}

// The fast 2D `uniform` (boxSpline, by columns) against `uniform-exact` at interior points (8
// corners, 0–23 G-only directions): rough random rasters of 10×7 to 66×42 points over [−1, 1]²
// (every point's (c, α) random; corners narrow, |a| ≤ 0.25 ≈ a cell of the coarsest, and wide,
// |a| ≤ 0.6) and the widget TF2 data/tf2/tangle.json (256², sharp widget edges) with directions of
// the tangle's scale. Issue 33 asks max |ΔE| ≤ 1e−3. Measured 2026-12-05: tangle.json 1.9e−4 (the
// tables' form before it: 7.3e−4), rough rasters 1.4e−3 (9.1e−4) with one dominant corner kept
// by Gauss–Legendre past 0.35 of var G (a TF2 that is noise at the cell scale against narrow
// laws, where the Edgeworth normal of G given X is coarsest); with up to two dominant boxes cut
// into pieces past 0.25 (later that day) 1.8e−4 and 6.4e−4. Over 2000 rough cases of each kind
// that form was 2.55e−3 (narrow corners) and 1.66e−3 (wide) off at worst, 12 of 4000 over 9e−4:
// the law of G given X to κ4 (Edgeworth) was too coarse for narrow laws on noise. With it to κ6
// (Gram–Charlier, exact to six moments) and corners cut past 0.15: 9.8e−4 and 4.1e−4 over those
// 4000 (1 over 9e−4); this test's 40 cases a raster (640): see its output. Box splines wider in x
// than the whole raster (the rough cases' wide corners: |a| up to 0.6 of a domain 2 wide) take
// the columns too, through the virtual basis functions beyond the raster.
TEST(Tf2BlurTables, BoxSplineByColumnsAgainstTheExactEvaluation) {
    std::mt19937_64 g(34);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    double worst = 0.0;
    int fallbacks = 0, count = 0;
    for (int raster = 0; raster < 16; ++raster) {
        const int i = raster % 8;
        const testing::Raster wide = roughRaster(g, 10 + 8 * i, 7 + 5 * i, -1.0, 1.0);
        const double aMax = raster < 8 ? 0.25 : 0.6, bMax = raster < 8 ? 0.6 : 0.3;
        worst = std::max(worst, boxSplineWorst(
                                    wide.r, 40,
                                    [&] {
                                        return testing::randomCase(
                                            g, 8, static_cast<int>(u(g) * 24), aMax, bMax, 0.15);
                                    },
                                    fallbacks, count));
    }
    const double rough = worst;
    const TransferFunction2D tf = tangleTf2();
    ASSERT_GT(tf.width, 0) << "data/tf2/tangle.json";
    const Tf2Raster<double> r = rasterOf(tf);
    // Centres over the widgets (x ∈ [−7, 13], G ∈ [0, 45]); corners up to 1.5 in x and 8 in G,
    // G-only up to 3: σ_X from a few to ~20 raster cells, σ_G ~ 10–60 cells.
    int tangleFallbacks = 0;
    const double tangle = boxSplineWorst(
        r, 40,
        [&] {
            testing::Case c =
                testing::randomCase(g, 8, 16 + static_cast<int>(u(g) * 8), 1.5, 8.0, 3.0);
            c.cx = -7.0 + 20.0 * u(g), c.cy = 45.0 * u(g);
            return c;
        },
        tangleFallbacks, count);
    EXPECT_EQ(tangleFallbacks, 0);  // interior points of a real TF2 take the columns
    std::printf(
        "uniform 2D fast: max |dE| rough rasters %.3g, tangle.json %.3g over %d cases, %d at "
        "the coarse exact settings\n",
        rough, tangle, count, fallbacks);
    EXPECT_LE(tangle, 1e-3);
    EXPECT_LE(rough, 1e-3);
    EXPECT_LE(fallbacks, count / 20);  // the columns, not their fallback, are what is measured
    EXPECT_GT(tangle, 1e-6);           // an approximation (else this checks nothing)
}

// A corner narrow in x that holds most of the rest of var G beside a wider G-only box (which is
// exact): the rest given X is then nearly that corner's box, far from a Gram–Charlier normal.
// Found by an outside-style sweep (2026-12-05: a 6×4×5 random model on a 64² rough TF2, 3.4e−3
// off `uniform-exact` and Monte Carlo) while corners were cut only when wider in G than the
// widest G-only box; cut whatever that box's width: 2.3e−4 over 80 points around it. Here: rough
// 64² rasters, X within about a column, G over ~10–40 rows, the corner's b 0.8–0.99 of the box's:
// 3.3e−4 (1.15e−3 with the old rule).
TEST(Tf2BlurTables, BoxSplineWithACornerDominatingBesideTheWidestGOnlyBox) {
    std::mt19937_64 g(41);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    double worst = 0.0;
    int fallbacks = 0, count = 0;
    for (int raster = 0; raster < 4; ++raster) {
        const testing::Raster rough = roughRaster(g, 64, 64, -1.0, 1.0);
        worst =
            std::max(worst, boxSplineWorst(
                                rough.r, 40,
                                [&] {
                                    testing::Case c = testing::randomCase(
                                        g, 8, 4 + static_cast<int>(u(g) * 12), 0.012, 0.03, 0.03);
                                    const double h = 0.3 + 0.3 * u(g);
                                    for (BoxDirection2& d : c.d)
                                        if (d.a != 0.0) {
                                            d.b = -(0.8 + 0.19 * u(g)) * h;
                                            break;
                                        }
                                    for (BoxDirection2& d : c.d)
                                        if (d.a == 0.0) {
                                            d.b = h;
                                            break;
                                        }
                                    return c;
                                },
                                fallbacks, count));
    }
    std::printf(
        "uniform 2D fast, a corner beside the widest G-only box: max |dE| %.3g over %d "
        "cases, %d at the coarse exact settings\n",
        worst, count, fallbacks);
    EXPECT_LE(worst, 1e-3);
    EXPECT_LE(fallbacks, count / 20);
}

// Corners nearly proportional in (a, b): G almost a function of X, so the law is a thin sliver
// (a review's case, 2026-12-05). Pieces of a cut corner would need a rest given X near 0, so most
// such samples take the exact evaluation, whose 32 node cells miss the sliver: random cases were
// up to 2.6e−2 off at those settings; expectedTf2UniformRefined doubles the cells while its
// refinement check is over 2e−4 (measured: 1.4e−4, 17 of the 24 cases there; at 32 cells only,
// 1.7e−2). Rough 66 × 42 rasters, X 15–67 cells wide, b = a·(1 ± ε) (data units), with and
// without 4 narrow G-only boxes.
TEST(Tf2BlurTables, BoxSplineWithNearlyProportionalCornersWithin1e3OfTheExactEvaluation) {
    std::mt19937_64 g(77);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const int W = 66, H = 42;
    const testing::Raster rough = roughRaster(g, W, H, -1.0, 1.0);
    const double cellX = 2.0 / (W - 1), cellY = 2.0 / (H - 1);
    double worst = 0.0;
    int fallbacks = 0, count = 0;
    for (const double A : {15.0, 67.0})
        for (const double eps : {0.02, 0.15})
            for (const int gOnly : {0, 4})
                worst = std::max(worst, boxSplineWorst(
                                            rough.r, 3,
                                            [&] {
                                                testing::Case c;
                                                c.cx = u(g) - 0.5, c.cy = u(g) - 0.5;
                                                double a[8], sum = 0.0;
                                                for (double& v : a)
                                                    sum += std::abs(v = 2 * u(g) - 1);
                                                for (const double v : a) {
                                                    const double ac = v * A / sum;
                                                    const double bc =
                                                        ac * (1 + eps * (2 * u(g) - 1));
                                                    c.d.push_back({ac * cellX, bc * cellX});
                                                }
                                                for (int i = 0; i < gOnly; ++i)
                                                    c.d.push_back({0.0, (2 * u(g) - 1) * cellY});
                                                return c;
                                            },
                                            fallbacks, count));
    std::printf(
        "uniform 2D fast, nearly proportional corners: max |dE| %.3g over %d cases, %d at "
        "the exact evaluation\n",
        worst, count, fallbacks);
    EXPECT_LE(worst, 1e-3);
}

// Below the y blur ladder (var G under 2·0.25² raster cells²) the columns take the raster's rows
// in closed form, the widest G-only box convolved exactly (edgeworthBoxRowWeights: differences
// of the Edgeworth CDF's antiderivatives). Laws of G that narrow with one wide G-only box (1–6
// rows) and a few narrower ones, on rough random rasters (every point random) and centres that
// put the box over the raster's ends (the masses beyond rows 0 and H − 1): no case at the
// fallback; measured 2026-12-05 1.7e−5 of `uniform-exact` (the Gauss–Legendre pieces it replaced:
// 1.69e−5; 1.85e−5 with X's tails of weight 1e−5 left out), held to 2e−4 (the box's density
// 0.3 % off gives 1.7e−3).
TEST(Tf2BlurTables, BoxSplineNarrowInGWithAWideGOnlyBoxAgainstTheExactEvaluation) {
    std::mt19937_64 g(35);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    double worst = 0.0;
    int fallbacks = 0, count = 0;
    for (int raster = 0; raster < 6; ++raster) {
        // 2/(H − 1) data units a row: corners' b ≤ 0.12 rows, so var G ≤ 8·0.12²/3 < 0.04 rows².
        const int W = 17 + 8 * raster, H = 9 + 4 * raster;
        const testing::Raster rough = roughRaster(g, W, H, -1.0, 1.0);
        const double row = 2.0 / (H - 1);
        worst = std::max(worst, boxSplineWorst(
                                    rough.r, 12,
                                    [&] {
                                        testing::Case c =
                                            testing::randomCase(g, 8, static_cast<int>(u(g) * 3),
                                                                0.3, 0.12 * row, 0.5 * row);
                                        c.d.push_back({0.0, (1.0 + 5.0 * u(g)) * row});
                                        c.cy = 2.2 * u(g) - 1.1;  // over the ends as well
                                        return c;
                                    },
                                    fallbacks, count));
    }
    std::printf(
        "uniform 2D fast, narrow in G with a wide G-only box: max |dE| %.3g over %d cases, "
        "%d at the coarse exact settings\n",
        worst, count, fallbacks);
    EXPECT_EQ(fallbacks, 0);
    EXPECT_LE(worst, 2e-4);
    EXPECT_GT(worst, 1e-7);  // an approximation (the Edgeworth law of G given X)
}

// Past the columns' bounds on one sample's work (expected_tf2_fast.cpp, kColumnsMax…) and on
// hostile values the fast 2D `uniform` takes the exact evaluation at the coarse settings (false,
// and the same values): G's reach over 1e6 raster cells, X's half support over 512 cells, over 32
// directions, a NaN direction.
TEST(Tf2BlurTables, BoxSplinePastItsBoundsTakesTheExactEvaluation) {
    std::mt19937_64 g(38);
    const testing::Raster rough = roughRaster(g, 33, 21, -1.0, 1.0);  // 16 cells a data unit in x
    const Tf2BlurTables tables(rough.r);
    ASSERT_TRUE(tables.available());
    std::vector<BoxDirection2> base;
    for (int i = 0; i < 8; ++i) base.push_back({0.01 + 0.01 * i, 0.02 * (i % 3) - 0.02});
    const auto check = [&](const char* what, double cy, std::vector<BoxDirection2> d) {
        double got[4], want[4];
        const int n = static_cast<int>(d.size());
        EXPECT_FALSE(tables.boxSpline(rough.r, 0.1, cy, d.data(), n, 0.0, got)) << what;
        expectedTf2UniformRefined(rough.r, 0.1, cy, d.data(), n, 0.0, want);
        for (int ch = 0; ch < 4; ++ch) EXPECT_EQ(got[ch], want[ch]) << what << " channel " << ch;
    };
    double got[4];
    EXPECT_TRUE(tables.boxSpline(rough.r, 0.1, 0.0, base.data(), 8, 0.0, got));  // within
    check("G far away", 1e5, base);                                              // 1e6 cells
    std::vector<BoxDirection2> wide = base;
    wide[0].a = 40.0;  // 640 cells
    check("X wider than 512 cells", 0.0, wide);
    std::vector<BoxDirection2> many = base;
    for (int i = 0; i < 25; ++i) many.push_back({0.0, 0.001});
    check("33 directions", 0.0, many);
    std::vector<BoxDirection2> nan = base;
    nan[3].b = std::nan("");
    double v[4];
    EXPECT_FALSE(tables.boxSpline(rough.r, 0.1, 0.0, nan.data(), 8, 0.0, v));
}

// The x series' cap, kColumnsMaxTerms = 4096 terms (docs/models.md): eight equal corners of
// a0 cells need the first m with (2/L)·min(1, 1/(ω_m a0))⁸·(4/ω_m²)·m < 1e−8 (ω_m = 2πm/L,
// L = 16a0 + 3; computed in Python): 4100 terms at a0 = 3.878e−4 cells, past the cap by less
// than one batch of 8 (taken before 2026-12-05, up to 4103), and 4061 at 3.92e−4, within it.
TEST(Tf2BlurTables, BoxSplinePastItsTermCapTakesTheExactEvaluation) {
    std::mt19937_64 g(38);
    const testing::Raster rough = roughRaster(g, 33, 21, -1.0, 1.0);  // 16 cells a data unit in x
    const Tf2BlurTables tables(rough.r);
    ASSERT_TRUE(tables.available());
    const auto corners = [](double a0Cells) {
        std::vector<BoxDirection2> d;
        for (int i = 0; i < 8; ++i) d.push_back({a0Cells / 16.0, 0.02 * (i % 3) - 0.02});
        return d;
    };
    double got[4];
    const std::vector<BoxDirection2> within = corners(3.92e-4), past = corners(3.878e-4);
    EXPECT_TRUE(tables.boxSpline(rough.r, 0.1, 0.0, within.data(), 8, 0.0, got));
    EXPECT_FALSE(tables.boxSpline(rough.r, 0.1, 0.0, past.data(), 8, 0.0, got));
}

// Real render samples: 7 calls of the fast 2D `uniform` in a 16² frame of the 64³ tangle (20
// members, q = 8, data/tf2/tangle.json; centre (x, G), tinyWidth and the 32 directions (a, b) in
// data units, to 7 digits): the five worst of 121 such calls for the tables' form of 2026-12-02
// (2.65e−2 … 1.06e−2 off uniform-exact) and the two worst after its 2026-12-03 repair (1.39e−3,
// 1.33e−3). By columns (2026-12-05): 8.8e−4, 1.3e−4, 1.5e−4, 1.3e−4, 6.8e−5, 5.0e−4, 6.2e−4;
// with the dominant boxes cut into pieces (later that day): 7.8e−6, 1.3e−4, 1.5e−4, 2.4e−6,
// 9.3e−5, 2.0e−5, 2.5e−6; with the G-only box folded into the law above the ladder: 2.9e−5,
// 2.1e−4, 2.4e−4, 1.5e−5, 9.3e−5, 5.2e−5, 5.7e−6.
TEST(Tf2BlurTables, BoxSplineOnRealTangleSamplesWithin1e3OfTheExactEvaluation) {
    struct Sample {
        double cx, cy, tinyWidth;
        std::vector<double> ab;  // a0, b0, a1, b1, …
    };
    const Sample samples[] = {
        {0.05690929,
         21.77423,
         5.683082e-08,
         {0.780809,  -1.730613,   0.09489601, -0.8138585,   0,          1.182548,
          0.3337127, 6.437646,    0,          -5.188643,    3.964827,   -6.529456,
          0,         -0.1295719,  0,          -0.2405481,   0.05754028, 0.7440591,
          0,         -0.5329615,  0.6246081,  -5.001068,    0,          -0.02591527,
          0,         0.2696195,   0,          1.781752,     1.142294,   22.68662,
          0,         -0.02313276, 0,          -0.05453114,  0,          0.2368162,
          0.1409666, 1.903146,    0,          -0.007692487, 0,          2.364114,
          0,         -13.57461,   0,          0.441087,     0,          -0.7892822,
          0,         -4.473882,   0,          0.09955934,   0,          1.490982,
          0,         7.02325,     0,          0.1409566,    0,          -0.2924249,
          0,         1.131556,    0,          0.0199159}},
        {3.248859,
         24.74562,
         5.683082e-08,
         {0.03168487, 1.654209,   0.1137279,  3.258214,   0,        0.1544472, 0.1966542,
          5.333384,   0,          0.1125571,  0.1123406,  5.234767, 0,         0.04164318,
          0,          -0.7189186, 1.005021,   3.579543,   0,        0.5257684, 0.370889,
          8.544667,   0,          0.2068157,  0,          1.37226,  0,         -0.8160227,
          0.8565669,  18.42453,   0,          0.4364195,  0,        -5.133649, 0,
          -3.024328,  3.261986,   -6.684513,  0,          1.360724, 0,         0.6407618,
          0,          0.3108812,  0,          -0.1060383, 0,        -2.658122, 0,
          1.930334,   0,          -0.7599103, 0,          4.882347, 0,         -3.283371,
          0,          -1.355894,  0,          -18.70952,  0,        -7.884288, 0,
          -3.600127}},
        {2.410811,
         24.74863,
         5.683082e-08,
         {4.249012,    4.257973,    0.352102,   -22.07835,   0,          22.90491,    0.2254515,
          -11.19293,   0,           13.13796,   0.6172541,   -5.657076,  0,           8.751755,
          0,           -1.791851,   0.02570678, -2.913947,   0,          1.360377,    0.08232645,
          -5.999246,   0,           0.6458719,  0,           1.927401,   0,           -1.368776,
          0.06330421,  -3.786461,   0,          0.578141,    0,          -0.150305,   0,
          -0.08541699, 0.004954558, -0.6119883, 0,           0.04717158, 0,           4.772361,
          0,           3.543127,    0,          -1.684134,   0,          -0.2732299,  0,
          0.2223857,   0,           -0.1338716, 0,           0.302686,   0,           -0.1120863,
          0,           -0.1082965,  0,          -0.02466365, 0,          -0.02346043, 0,
          -0.0107629}},
        {-1.928037,
         10.27049,
         5.683082e-08,
         {0.2438704, 18.67577,    0.1250266, 9.858074,    0,          -0.2286632,
          0.0209806, 1.011377,    0,         0.3755017,   4.106223,   -3.834909,
          0,         1.636464,    0,         0.03938559,  0.01339373, 0.6760141,
          0,         0.30848,     1.677948,  2.236939,    0,          1.073561,
          0,         -0.02301303, 0,         -0.02431776, 0.265127,   -7.770688,
          0,         0.09209616,  0,         0.009496982, 0,          -0.005021879,
          0.1244922, -3.366548,   0,         0.07992195,  0,          -2.651682,
          0,         8.352815,    0,         -14.67198,   0,          2.342681,
          0,         4.293197,    0,         -6.966087,   0,          -0.2201444,
          0,         -0.4007898,  0,         -1.331527,   0,          0.1489478,
          0,         -0.3451625,  0,         -0.7991182}},
        {5.81554,
         24.20491,
         5.683082e-08,
         {0.0002912961,
          0.02536876,
          0.004582221,
          -0.1835114,
          0,
          0.001904596,
          0.007595604,
          0.7566209,
          0,
          -0.0001011103,
          0.008511701,
          0.9732481,
          0,
          -0.0001619746,
          0,
          -0.02199045,
          0.1114463,
          -3.06754,
          0,
          -0.002523028,
          0.1746575,
          -2.234822,
          0,
          -0.003997436,
          0,
          0.05054726,
          0,
          0.001896933,
          0.3367614,
          42.72361,
          0,
          -0.006760623,
          0,
          -0.4446499,
          0,
          0.07528958,
          4.092989,
          -1.112117,
          0,
          -0.1251874,
          0,
          0.03819883,
          0,
          -0.0032588,
          0,
          0.007428887,
          0,
          -0.9599308,
          0,
          -0.04271411,
          0,
          0.106292,
          0,
          1.369474,
          0,
          0.1059396,
          0,
          0.1952158,
          0,
          -36.58209,
          0,
          1.851559,
          0,
          4.450149}},
        {-0.3194845,
         25.64375,
         5.683082e-08,
         {0.4933521,  4.411849,    2.713109, -2.83664,     0,          0.5525902,
          0.05136408, 2.687821,    0,        -2.126538,    0.179414,   1.571383,
          0,          0.03592298,  0,        -2.355527,    0.5294992,  22.41936,
          0,          -17.8885,    2.506089, -3.08176,     0,          0.2905954,
          0,          0.09309387,  0,        0.2868142,    0.05166907, 2.694265,
          0,          0.005425857, 0,        -0.6522023,   0,          2.805031,
          0.3297012,  13.89905,    0,        0.02369056,   0,          0.4643354,
          0,          -1.321733,   0,        -0.03106633,  0,          -2.820316,
          0,          -8.51329,    0,        -0.1799501,   0,          0.06303228,
          0,          0.2691701,   0,        -0.003495839, 0,          -0.2906542,
          0,          2.011307,    0,        -0.02625931}},
        {-0.9664749,
         13.75024,
         5.683082e-08,
         {0.5531021,   -25.94946, 0.1013915,   -3.653442,  0,           -1.626067,   0.04420042,
          -1.793061,   0,         -0.3221056,  2.007574,   -0.1031111,  0,           -2.892432,
          0,           0.1798054, 0.009748356, -0.2893643, 0,           -0.07454339, 1.207924,
          13.08403,    0,         -0.6668662,  0,          -0.1022326,  0,           0.02793664,
          0.4220978,   2.658488,  0,           -0.1691287, 0,           0.01767066,  0,
          0.005424974, 0.1006602, 1.72949,     0,          -0.07836266, 0,           -13.98444,
          0,           -1.241749, 0,           19.47487,   0,           2.163,       0,
          -0.5206469,  0,         7.109347,    0,          -0.7818713,  0,           0.1958716,
          0,           1.653361,  0,           0.2443337,  0,           0.02061375,  0,
          0.3819284}},
    };
    const TransferFunction2D tf = tangleTf2();
    ASSERT_GT(tf.width, 0) << "data/tf2/tangle.json";
    const Tf2Raster<double> r = rasterOf(tf);
    const Tf2BlurTables tables(r);
    double worst = 0.0;
    for (const Sample& s : samples) {
        std::vector<BoxDirection2> d(s.ab.size() / 2);
        for (std::size_t k = 0; k < d.size(); ++k) d[k] = {s.ab[2 * k], s.ab[2 * k + 1]};
        const int n = static_cast<int>(d.size());
        double got[4], want[4];
        EXPECT_TRUE(tables.boxSpline(r, s.cx, s.cy, d.data(), n, s.tinyWidth, got));  // columns
        Tf2UniformExactOptions opt;
        expectedTf2UniformExact(r, s.cx, s.cy, d.data(), n, s.tinyWidth, opt, want);
        double e = 0.0;
        for (int ch = 0; ch < 4; ++ch) e = std::max(e, std::abs(got[ch] - want[ch]));
        std::printf("real tangle sample (%.4g, %.4g): |dE| %.3g\n", s.cx, s.cy, e);
        worst = std::max(worst, e);
    }
    EXPECT_LE(worst, 1e-3);
}

// 1–8 corners (directions with a ≠ 0; fewer where voxels have zero spread): 2–8 take the columns
// since 2026-12-05 (κ6 and the cut rule; before, with κ4, up to 5.6e−3 off, so fewer than 8 took
// the exact evaluation at the coarse kUniform2DFast settings), one corner the exact evaluation.
// Measured: 2.4e−4, 14 of the 80 cases at the coarse settings (5760 cases of 2–7 corners, a
// larger draw: 8.1e−4).
TEST(Tf2BlurTables, BoxSplineWithFewCornersWithin1e3OfTheExactEvaluation) {
    std::mt19937_64 g(36);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    double worst = 0.0;
    int fallbacks = 0, count = 0;
    for (int raster = 0; raster < 8; ++raster) {
        const testing::Raster wide = roughRaster(g, 10 + 8 * raster, 7 + 5 * raster, -1.0, 1.0);
        worst = std::max(worst, boxSplineWorst(
                                    wide.r, 10,
                                    [&] {
                                        return testing::randomCase(
                                            g, 1 + static_cast<int>(u(g) * 8),
                                            static_cast<int>(u(g) * 24), 0.25, 0.6, 0.15);
                                    },
                                    fallbacks, count));
    }
    std::printf(
        "uniform 2D fast, 1-8 corners: max |dE| %.3g over %d cases, %d at the coarse "
        "exact settings\n",
        worst, count, fallbacks);
    EXPECT_LE(worst, 1e-3);
    EXPECT_LE(fallbacks, count / 4);  // one corner (1 in 8 of the draws) and past the node cap
}

}  // namespace
}  // namespace udvr
