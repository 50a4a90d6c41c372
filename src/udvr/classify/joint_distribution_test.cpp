// The 2D kernels' joint distributions (JointDistributionAt) against the kernels' own
// classification and against Monte Carlo draws of each model's definition.
#include "udvr/classify/joint_distribution.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <type_traits>
#include <utility>

#include "udvr/classify/classify_test_util.h"
#include "udvr/classify/model_families.h"

namespace udvr {
namespace {

// A random 4×3×3 model (q = 8) on a random grid and a rough random TF2 (10×7) over its range.
std::pair<ModelVolume, TransferFunction2D> randomModelAndTf2(CounterRng& rng) {
    const std::array<int, 3> dims{4, 3, 3};
    ModelVolume m = testing::randomModel(rng, dims, 8);
    m.grid = testing::randomGrid(rng, dims);
    const auto range = modelDataRange(m);
    TransferFunction2D t = testing::randomTf2(rng, 10, 7, range.first, range.second, 0.0, 3.0);
    return {std::move(m), std::move(t)};
}

// One joint distribution per 2D model (JointDistributionAt) and one TF2 expectation over any
// of them (expectedTf2Over, piece by piece): every 2D kernel's double body equals it. The
// quantile kernels' polyline walk (row tables, runs) against segment-by-segment means: 1e−9;
// uniform-exact (expectedTf2UniformExact on both sides): 1e−12. `uniform` (alias uniform-fast)
// by columns: on these rough random rasters (10×7 points, α random, a quarter 0; laws as wide in G
// as the raster, often dominated by one corner's box) 6.8e−4 off (measured 2026-12-05; 7.3e−3
// before the dominant corner was kept by Gauss–Legendre), held here to the 1e−3; the fast
// gaussian (prefiltered tables) 2.8e−5, held to 1e−4. Random models, grids, TF2s
// and points.
TEST(JointDistribution, Every2DKernelClassifiesAsTheExpectationOverItsDistribution) {
    // The fast forms (`uniform` and its alias `uniform-fast`, `gaussian`): their error against
    // the exact expectation, per family: [0] uniform, [1] gaussian.
    double fastSq[2] = {}, fastMax[2] = {};
    int withDistribution[2] = {};  // kernels with reconstruct: [0] mean, [1] the quantile family
    int fastCount[2] = {};
    for (int seed = 0; seed < 4; ++seed) {
        CounterRng rng(811 + seed, 0, 0);
        const auto [m, t] = randomModelAndTf2(rng);
        for (ModelKind kind : allModelKinds()) {
            if (!modelFamily(kind).makeKernel2D) continue;
            const bool exactUniform = kind == ModelKind::UniformExact;
            const int fast = kind == ModelKind::Uniform || kind == ModelKind::UniformFast ? 0
                             : kind == ModelKind::Gaussian                                ? 1
                                                                                          : -1;
            const int points = exactUniform ? 3 : 20;
            withKernel2D(m, kind, t, ClassifyOptions{}, [&](const auto& k) {
                // The kernels that build their distribution over the lane type hand on a
                // Distribution2D over double and lanes (distributions_2d.h; compile time).
                using K = std::decay_t<decltype(k)>;
                if constexpr (requires(const Cell<double>& c) {
                                  k.template reconstruct<double>(c, true,
                                                                 []<Distribution2D D>(const D&) {});
                              }) {
                    [[maybe_unused]] const auto onLanes = [&](const Cell<lanes::Vf>& c) {
                        k.template reconstruct<lanes::Vf>(c, lanes::allTrue<lanes::Vf>(),
                                                          []<Distribution2D D>(const D&) {});
                    };
                    ++withDistribution[std::is_same_v<K, Quantile2DKernel>];
                }
                for (int i = 0; i < points; ++i) {
                    const Cell<double> cell =
                        cellAt<double>(CellGeometry(m.grid), static_cast<float>(3 * rng.uniform()),
                                       static_cast<float>(2 * rng.uniform()),
                                       static_cast<float>(2 * rng.uniform()));
                    double kernel[4], over[4];
                    k.finish(k.template load<double>(cell, true), kernel);
                    JointPointDistribution d;
                    jointDistributionAt(k, cell, d);
                    double mass = 0.0;
                    for (const auto& p : d.points) mass += p.mass;
                    for (const auto& s : d.segments) mass += s.mass;
                    for (const auto& n : d.normals) mass += n.mass;
                    for (const auto& b : d.boxSplines) mass += b.mass;
                    ASSERT_NEAR(mass, 1.0, 1e-12) << modelName(kind);
                    expectedTf2Over(k.tfExact, d, over);
                    if (fast >= 0) {
                        for (int ch = 0; ch < 4; ++ch) {
                            const double e = std::fabs(kernel[ch] - over[ch]);
                            fastSq[fast] += e * e;
                            fastMax[fast] = std::max(fastMax[fast], e);
                            ++fastCount[fast];
                        }
                        continue;
                    }
                    const double tol = exactUniform ? 1e-12 : 1e-9;
                    for (int ch = 0; ch < 4; ++ch)
                        ASSERT_NEAR(kernel[ch], over[ch], tol)
                            << modelName(kind) << " seed " << seed << " channel " << ch;
                }
            });
        }
    }
    EXPECT_GT(withDistribution[0], 0);
    EXPECT_GT(withDistribution[1], 0);
    for (int f = 0; f < 2; ++f)
        std::printf(
            "%s 2D (fast) against its exact expectation: max %.3g, RMS %.3g over %d values\n",
            f == 0 ? "uniform" : "gaussian", fastMax[f], std::sqrt(fastSq[f] / fastCount[f]),
            fastCount[f]);
    // docs/models.md: issue 33's bound for the fast forms.
    EXPECT_LE(fastMax[0], 1e-3);
    EXPECT_LE(fastMax[1], 1e-4);  // the Gaussian's tables
}

// The fast 2D `uniform` against `uniform-exact` on a cell's faces, edges and grid points (one
// to three coordinates whole), where fewer than 8 corners have weight: within issue 33's 1e−3.
// (The kernel takes the coarse exact settings there: by columns such synthetic box splines were up
// to 5.6e−3 off, Tf2BlurTables.BoxSplineWithFewCorners…; this test holds the contract, not that
// choice.)
TEST(Uniform2D, FastFormWithin1e3OfExactOnFacesEdgesAndGridPoints) {
    double worst = 0.0;
    int count = 0;
    for (int seed = 0; seed < 4; ++seed) {
        CounterRng rng(907 + seed, 0, 0);
        const auto [m, t] = randomModelAndTf2(rng);
        for (int i = 0; i < 6; ++i) {
            float at[3] = {static_cast<float>(3 * rng.uniform()),
                           static_cast<float>(2 * rng.uniform()),
                           static_cast<float>(2 * rng.uniform())};
            const int whole = 1 + i % 3;  // axes on grid planes: a face, an edge, a grid point
            for (int a = 0; a < whole; ++a) at[(a + i) % 3] = std::floor(at[(a + i) % 3]);
            const Cell<double> cell = cellAt<double>(CellGeometry(m.grid), at[0], at[1], at[2]);
            double e[2][4];
            const ModelKind kinds[2] = {ModelKind::Uniform, ModelKind::UniformExact};
            for (int k = 0; k < 2; ++k)
                withKernel2D(m, kinds[k], t, ClassifyOptions{}, [&](const auto& kernel) {
                    kernel.finish(kernel.template load<double>(cell, true), e[k]);
                });
            for (int ch = 0; ch < 4; ++ch) worst = std::max(worst, std::fabs(e[0][ch] - e[1][ch]));
            ++count;
        }
    }
    std::printf("uniform 2D (fast) on faces, edges and grid points: max |dE| %.3g over %d points\n",
                worst, count);
    EXPECT_LE(worst, 1e-3);
}

// JointMoments against the moments of draws from each piece's law (fixed seed, 4·10⁵ draws:
// the means within 5 standard errors, the covariance entries within 3 %).
TEST(JointDistribution, MomentsMatchMonteCarloOfEachPiece) {
    CounterRng rng(97, 0, 0);
    BoxSpline2 b;
    b.cx = 3.0;
    b.cg = -1.0;
    b.n = 3;
    b.d[0] = {0.5, 0.2};
    b.d[1] = {-0.3, 0.7};
    b.d[2] = {0.1, 0.0};
    JointMoments m;
    m.point(1.0, 2.0, 0.2);
    m.segment(0.0, 1.0, 2.0, 5.0, 0.3);
    m.normal(Normal2{-1.0, 0.5, 0.4, -0.1, 0.2}, 0.1);
    m.boxSpline(b, 0.4);
    const int n = 400000;
    double sx = 0, sg = 0, sxx = 0, sxg = 0, sgg = 0;
    for (int i = 0; i < n; ++i) {
        const double u = rng.uniform();
        double x, g;
        if (u < 0.2) {
            x = 1.0;
            g = 2.0;
        } else if (u < 0.5) {
            const double t = rng.uniform();
            x = 2.0 * t;
            g = 1.0 + 4.0 * t;
        } else if (u < 0.6) {
            // (X, G) = μ + L·z with L the Cholesky factor of [[0.4, −0.1], [−0.1, 0.2]].
            const double z1 = rng.normal(), z2 = rng.normal();
            const double l11 = std::sqrt(0.4), l21 = -0.1 / l11, l22 = std::sqrt(0.2 - l21 * l21);
            x = -1.0 + l11 * z1;
            g = 0.5 + l21 * z1 + l22 * z2;
        } else {
            x = b.cx;
            g = b.cg;
            for (int d = 0; d < b.n; ++d) {
                const double t = 2.0 * rng.uniform() - 1.0;
                x += t * b.d[d].a;
                g += t * b.d[d].b;
            }
        }
        sx += x;
        sg += g;
        sxx += x * x;
        sxg += x * g;
        sgg += g * g;
    }
    const double mx = sx / n, mg = sg / n;
    const double vxx = sxx / n - mx * mx, vxg = sxg / n - mx * mg, vgg = sgg / n - mg * mg;
    EXPECT_NEAR(m.mass, 1.0, 1e-15);
    EXPECT_NEAR(m.mx, mx, 5.0 * std::sqrt(vxx / n));
    EXPECT_NEAR(m.mg, mg, 5.0 * std::sqrt(vgg / n));
    EXPECT_NEAR(m.varX(), vxx, 0.03 * vxx);
    EXPECT_NEAR(m.covXG(), vxg, 0.03 * std::sqrt(vxx * vgg));
    EXPECT_NEAR(m.varG(), vgg, 0.03 * vgg);
}

// A narrow distribution far from 0 keeps its variance (no E[G²] − E[G]² cancellation).
TEST(JointDistribution, MomentsOfANarrowDistributionFarFromZero) {
    JointMoments m;
    m.segment(1e8, 1e8, 1e8 + 1e-3, 1e8 + 2e-3, 0.5);
    m.segment(1e8 + 1e-3, 1e8 + 2e-3, 1e8 + 3e-3, 1e8 + 2e-3, 0.5);
    // G: U[1e8, 1e8 + 2e−3] and the point 1e8 + 2e−3, each with mass ½ — mixture variance
    // ½·(4e−6/12) + ¼·(1e−3)² (the means 1e8 + 1e−3 and 1e8 + 2e−3 differ by 1e−3).
    const double want = 0.5 * 4e-6 / 12.0 + 0.25 * 1e-6;
    EXPECT_NEAR(m.varG(), want, 1e-4 * want);  // the inputs themselves carry 1e−8 rounding
}

}  // namespace
}  // namespace udvr
