// Bivariate fields with a 2D TF (SPEC §9 --second): per-cell moments against closed forms,
// every model's bivariate kernel against its 1D kernel (TF2 constant in y; and, with the axes
// swapped, constant in x), the lane and float bodies against the double body. The probe and the
// renderer are checked against the independent reference in
// python/tests/test_reference_bivariate.py.
#include "udvr/classify/model_kernels_bivariate.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <type_traits>
#include <vector>

#include "udvr/classify/classify_test_util.h"
#include "udvr/classify/kernel_test_util.h"
#include "udvr/classify/model_families.h"
#include "udvr/classify/transfer_function_2d.h"

namespace udvr {
namespace {

// Σ_i (i + s)^d over the per-cell moments: E[U^d] of the (clamped) raster coordinate.
double rasterMoment(const AxisMoments& m, int d) {
    double sum = 0.0;
    for (int i = m.lo(); i <= m.hi(); ++i) {
        const double* c = m.at(i);
        if (d == 0) sum += c[0];
        if (d == 1) sum += i * c[0] + c[1];
        if (d == 2) sum += i * i * c[0] + 2.0 * i * c[1] + c[2];
    }
    return sum;
}

TEST(Bivariate, AxisMomentsHoldTheMassMeanAndVarianceOfEachPiece) {
    const RasterAxis axis{-3.0, 2.0, 41};  // points at −3, −2.5, …, 17: 40 cells of 0.5
    AxisMoments m;
    const auto check = [&](const char* what, double mean, double var, double tol) {
        SCOPED_TRACE(what);
        const double mu = axis.coordinate(mean), s2 = var * axis.inv * axis.inv;
        EXPECT_NEAR(rasterMoment(m, 0), 1.0, 1e-12);
        EXPECT_NEAR(rasterMoment(m, 1), mu, tol);
        EXPECT_NEAR(rasterMoment(m, 2), mu * mu + s2, tol * (1 + std::abs(mu)));
        // 0 ≤ s ≤ 1 in every cell: m0 ≥ m1 ≥ m2 ≥ 0, up to the differences' rounding
        // (ε × the support in cells squared).
        for (int i = m.lo(); i <= m.hi(); ++i) {
            const double* c = m.at(i);
            EXPECT_GE(c[0], c[1] - 1e-12);
            EXPECT_GE(c[1], c[2] - 1e-12);
            EXPECT_GE(c[2], -1e-12);
        }
    };
    m.reset(axis);
    m.point(4.3, 1.0);
    check("point", 4.3, 0.0, 1e-12);
    m.reset(axis);
    m.uniform(1.1, 6.35, 1.0);
    check("uniform", 0.5 * (1.1 + 6.35), 5.25 * 5.25 / 12.0, 1e-12);
    m.reset(axis);
    m.normal(7.2, 1.3, 1.0);
    check("normal", 7.2, 1.3 * 1.3, 1e-10);
    m.reset(axis);
    m.normal(7.2, 0.01, 1.0);  // narrower than a cell
    check("narrow normal", 7.2, 1e-4, 1e-10);
    UniformSum u;
    const double lo[8] = {0, 1, 2, 0.5, 1, 1, 3, 2}, hi[8] = {4, 2.5, 2.1, 5, 1, 3, 3.2, 7};
    const double w[8] = {0.1, 0.2, 0.05, 0.15, 0.1, 0.2, 0.1, 0.1};
    u = makeUniformSum(lo, hi, w, 1e-12);
    m.reset(axis);
    m.boxSpline(u, 1.0);
    check("box spline", u.mean(), u.variance(), 1e-10);
    // Mixtures add; masses outside the domain sit on its end lines.
    m.reset(axis);
    m.normal(-50.0, 1.0, 0.25);
    m.uniform(20.0, 30.0, 0.5);
    m.point(5.0, 0.25);
    EXPECT_NEAR(rasterMoment(m, 0), 1.0, 1e-12);
    EXPECT_NEAR(m.at(0)[0], 0.25, 1e-12);  // all of the normal at the first line
    EXPECT_NEAR(m.at(0)[1], 0.0, 1e-12);
    EXPECT_NEAR(m.at(39)[2], 0.5, 1e-12);  // the uniform at the last line (s = 1)
    // reset() clears what the last sample touched.
    m.reset(axis);
    EXPECT_GT(m.lo(), m.hi());
    m.point(0.0, 1.0);
    EXPECT_EQ(rasterMoment(m, 0), 1.0);
}

// The TF2 with x and y swapped.
TransferFunction2D transposed(const TransferFunction2D& t) {
    TransferFunction2D s = t;
    s.width = t.height;
    s.height = t.width;
    s.x0 = t.y0;
    s.x1 = t.y1;
    s.y0 = t.x0;
    s.y1 = t.x1;
    for (int j = 0; j < t.height; ++j)
        for (int i = 0; i < t.width; ++i)
            for (int ch = 0; ch < 4; ++ch)
                s.rgba[(static_cast<std::size_t>(i) * s.width + j) * 4 + ch] =
                    t.rgba[(static_cast<std::size_t>(j) * t.width + i) * 4 + ch];
    return s;
}

// A model whose every array describes the constant c with no spread.
ModelVolume constantModel(const ModelVolume& like, float c) {
    ModelVolume m = like;
    for (auto* a : {&m.mean, &m.min, &m.max, &m.quantiles, &m.iqr, &m.members})
        std::fill(a->begin(), a->end(), c);
    std::fill(m.stddev.begin(), m.stddev.end(), 0.f);
    const int k = m.gmmComponents;
    for (std::size_t v = 0; v < m.voxelCount(); ++v)
        for (int i = 0; i < k; ++i) {
            m.gmm[v * 3 * k + i] = i == 0 ? 1.f : 0.f;
            m.gmm[v * 3 * k + k + i] = c;
            m.gmm[v * 3 * k + 2 * k + i] = 0.f;
        }
    return m;
}

TEST(Bivariate, EveryModelReducesToIts1DKernelAlongEitherAxis) {
    CounterRng rng(21, 0, 0);
    const ModelVolume m = testing::randomModel(rng, {4, 4, 3}, 8);
    TransferFunction1D tf = testing::randomTf(rng, -5.0, 5.0);
    for (double& x : tf.colorX) x = 0.25 * std::round(4 * x);
    for (double& x : tf.opacityX) x = 0.25 * std::round(4 * x);
    for (auto* xs : {&tf.colorX, &tf.opacityX})  // steps cannot be rasterised
        for (std::size_t i = 1; i < xs->size(); ++i)
            (*xs)[i] = std::max((*xs)[i], (*xs)[i - 1] + 0.25);
    // TF2(x, y) = TF(x): the second field (a constant) must not matter; swapped, the first.
    const TransferFunction2D t = transferFunction2DFrom1D(tf, 81, -10.0, 10.0, -1.0, 2.0);
    const TransferFunction2D ts = transposed(t);
    const ModelVolume c = constantModel(m, 0.7f);
    for (ModelKind kind : allModelKinds()) {
        if (!modelFamily(kind).makeKernel) continue;
        for (int trial = 0; trial < 20; ++trial) {
            const float p[3] = {static_cast<float>(rng.uniform() * 3),
                                static_cast<float>(rng.uniform() * 3),
                                static_cast<float>(rng.uniform() * 2)};
            double one[4], two[4], swapped[4];
            // The bivariate uniform is the exact box spline for every uniform name (the fast 1D
            // form, `uniform` since issue 33, is tested against it in uniform_fast_test.cpp).
            const bool uniform = kind == ModelKind::Uniform || kind == ModelKind::UniformFast;
            const ModelKind one1D = uniform ? ModelKind::UniformExact : kind;
            withKernel(m, one1D, tf,
                       [&](const auto& k) { classifyAt<double>(k, p[0], p[1], p[2], one); });
            withKernelBivariate(m, c, kind, t, {}, [&](const auto& k) {
                classifyAt<double>(k, p[0], p[1], p[2], two);
            });
            withKernelBivariate(c, m, kind, ts, {}, [&](const auto& k) {
                classifyAt<double>(k, p[0], p[1], p[2], swapped);
            });
            for (int ch = 0; ch < 4; ++ch) {
                EXPECT_NEAR(two[ch], one[ch], 1e-7) << modelName(kind) << " ch " << ch;
                EXPECT_NEAR(swapped[ch], one[ch], 1e-7) << modelName(kind) << " ch " << ch;
            }
        }
    }
}

// Every bivariate model's lanes (and a float thread) reconstruct both fields over their own type
// once per batch, then take E[TF2] per lane in double from lane l's distributions: they differ
// from the double body only by float reconstruction (values rounded to ~6e−8 relative, so E
// moves by that × the TF2's slope in raster cells, ~1e−7 here) and the float output (6e−8).
// Held to 2e−6 (what the mean, gaussian and quantile-range lanes were held to before) over
// q = 8 (a batch's boundaries as transposed rows) and q = 40 (more than kMaxRowBoundaries on
// AVX-512: gathered per boundary), 40 members (two blocks of rows on AVX2).
/// A Bivariate2DKernel whose lanes and float threads always take loadOverLanes (load sends
/// members to the double body, for speed): the lane test checks that body for every model.
struct LaneBodyOf : Bivariate2DKernel {
    template <class T>
    Classified<T> load(const Cell<T>& c, lanes::MaskOf<T> live) const {
        return loadOverLanes<T>(c, live);
    }
};

TEST(Bivariate, LaneAndFloatBodiesMatchTheDoubleBody) {
    CounterRng rng(22, 0, 0);
    const TransferFunction2D t = [&] {
        TransferFunction2D r;
        r.width = 9;
        r.height = 7;
        r.x0 = -4;
        r.x1 = 4;
        r.y0 = -3;
        r.y1 = 5;
        for (int k = 0; k < r.width * r.height; ++k) {
            for (int ch = 0; ch < 3; ++ch) r.rgba.push_back(static_cast<float>(rng.uniform()));
            r.rgba.push_back(rng.uniform() < 0.25 ? 0.f : static_cast<float>(rng.uniform()));
        }
        return r;
    }();
    for (int q : {8, 40}) {
        const ModelVolume a = testing::randomModel(rng, {5, 4, 3}, q);
        const ModelVolume b = testing::randomModel(rng, {5, 4, 3}, q);
        for (ModelKind kind : allModelKinds()) {
            if (!modelFamily(kind).makeBivariate) continue;
            // members was up to 0.6 off here: GCC 12 kept inDoublePerLane's lane bits in a
            // stack slot written 16 bits and read 32 wide (lanes 16–31 ran; lanes::bits).
            const std::string what = std::string(modelName(kind)) + " q " + std::to_string(q);
            withKernelBivariate(a, b, kind, t, {}, [&](const auto& k) {
                double worst;
                if constexpr (std::is_same_v<std::decay_t<decltype(k)>, Bivariate2DKernel>)
                    worst = testing::worstLaneError(LaneBodyOf{k}, rng, {5, 4, 3}, what, 60);
                else
                    worst = testing::worstLaneError(k, rng, {5, 4, 3}, what, 60);
                char text[32];
                std::snprintf(text, sizeof text, "%.3g", worst);
                RecordProperty(what, text);
                EXPECT_LT(worst, 2e-6) << what;
            });
        }
    }
}

TEST(Bivariate, GridsThatDifferAndGmmMcAreUserErrors) {
    CounterRng rng(23, 0, 0);
    const ModelVolume a = testing::randomModel(rng, {4, 4, 3}, 8);
    ModelVolume b = testing::randomModel(rng, {4, 3, 3}, 8);
    const TransferFunction2D t = transferFunction2DFrom1D(testing::randomTf(rng, -1, 1), 5, -1, 1);
    const auto none = [](const auto&) {};
    EXPECT_THROW(withKernelBivariate(a, b, ModelKind::Gaussian, t, {}, none), UdvrError);
    ModelVolume shifted = a;
    shifted.grid.origin[1] += 0.5;
    EXPECT_THROW(withKernelBivariate(a, shifted, ModelKind::Gaussian, t, {}, none), UdvrError);
    EXPECT_THROW(withKernelBivariate(a, a, ModelKind::GmmMc, t, {}, none), UdvrError);
    ModelVolume noQuantiles = a;
    noQuantiles.quantiles.clear();
    EXPECT_THROW(withKernelBivariate(a, noQuantiles, ModelKind::QuantileRange, t, {}, none),
                 UdvrError);
}

}  // namespace
}  // namespace udvr
