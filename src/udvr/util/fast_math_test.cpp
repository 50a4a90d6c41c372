// Error bounds of the vector math in fast_math.h against libm, sampled densely over the ranges
// the estimators use.
#include "udvr/util/fast_math.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "udvr/util/lanes.h"
#include "udvr/util/normal_cdf.h"

namespace udvr::detail {
namespace {

using lanes::V8d;
using lanes::V8f;
using lanes::V8i;
using V16f = lanes::Vec<float, 16>;

TEST(FastMath, ExpFloatRelativeErrorBelow2_5e7) {
    double worst = 0.0;
    for (int i = 0; i < 200000; i += 16) {
        V16f x;
        for (int l = 0; l < 16; ++l) x[l] = -87.f * static_cast<float>(i + l) / 200000.f;
        const V16f y = expNonPositive(x);
        for (int l = 0; l < 16; ++l) {
            const double ref = std::exp(static_cast<double>(x[l]));
            worst = std::max(worst, std::fabs(y[l] - ref) / ref);
        }
    }
    EXPECT_LT(worst, 2.5e-7);  // truncation 1.2e−7 plus float rounding
    // Clamped below −87 (also −∞): e^−87, a negligible but finite weight.
    V16f x = splat<V16f>(-1000.f);
    x[1] = -std::numeric_limits<float>::infinity();
    x[2] = 0.f;
    const V16f y = expNonPositive(x);
    EXPECT_NEAR(y[0], std::exp(-87.0), 1e-6 * std::exp(-87.0));
    EXPECT_EQ(y[0], y[1]);
    EXPECT_EQ(y[2], 1.f);
}

TEST(FastMath, LogFloatAbsoluteErrorBound) {
    double worst = 0.0;
    for (int i = 0; i < 4000; ++i) {
        V8f s;
        for (int l = 0; l < 8; ++l)
            s[l] = static_cast<float>(std::exp(-30.0 + 60.0 * (8 * i + l) / 32000.0));
        const V8f y = logPositive(s);
        for (int l = 0; l < 8; ++l) {
            const double ref = std::log(static_cast<double>(s[l]));
            worst = std::max(worst, std::fabs(y[l] - ref) / (1.5e-7 + 6e-8 * std::fabs(ref)));
        }
    }
#ifdef __FMA__
    EXPECT_LT(worst, 1.0);  // |error| < 1.5e−7 + 6e−8·|log s|
#else
    // Without FMA every Horner step rounds twice (UDVR_NATIVE=OFF on x86-64: 1.6× seen).
    EXPECT_LT(worst, 2.0);
#endif
}

TEST(FastMath, LogDoubleAbsoluteErrorBound) {
    double worst = 0.0;
    for (int i = 0; i < 4000; ++i) {
        V8d s;
        for (int l = 0; l < 8; ++l) s[l] = std::exp(-300.0 + 600.0 * (8 * i + l) / 32000.0);
        const V8d y = logPositiveD(s);
        for (int l = 0; l < 8; ++l) {
            const double ref = std::log(s[l]);
            worst = std::max(worst, std::fabs(y[l] - ref) / (1e-15 * (1.0 + std::fabs(ref))));
        }
    }
    EXPECT_LT(worst, 1.0);  // |error| < 1e−15·(1 + |log s|)
}

TEST(FastMath, SplitExponentIsExact) {
    V8f s{1.f, 1.5f, 2.f, 3.f, 1024.f, 0x1.fffffep0f, 7e30f, 1.0001f};
    V8i e{};
    const V8f f = splitExponent(s, e);
    for (int l = 0; l < 8; ++l) {
        EXPECT_GE(f[l], 1.f);
        EXPECT_LT(f[l], 2.f);
        EXPECT_EQ(std::ldexp(static_cast<double>(f[l]), e[l]), static_cast<double>(s[l]));
    }
}

TEST(FastMath, ExpDoubleRelativeErrorBelow3e13) {
    double worst = 0.0;
    for (int i = 0; i < 100000; i += 8) {
        V8d x;
        for (int l = 0; l < 8; ++l) x[l] = -708.0 * (i + l) / 100000.0;
        const V8d y = expNonPositiveD(x);
        for (int l = 0; l < 8; ++l) {
            const double ref = std::exp(x[l]);
            worst = std::max(worst, std::fabs(y[l] - ref) / ref);
        }
    }
    EXPECT_LT(worst, 3e-13);
    V8d x = splat<V8d>(-800.0);
    x[1] = -INFINITY;
    const V8d y = expNonPositiveD(x);
    EXPECT_EQ(y[0], 0.0);
    EXPECT_EQ(y[1], 0.0);
}

TEST(FastMath, NormalAtOnLanesMatchesScalar) {
    for (int i = 0; i < 2000; ++i) {
        V8d u;
        for (int l = 0; l < 8; ++l) u[l] = -12.0 + 24.0 * (8 * i + l) / 16000.0;
        const NormalAt<V8d> n = normalAt(u, ExpNonPositiveOf{});
        const V8d c = n.cdf, p = n.pdf;
        for (int l = 0; l < 8; ++l) {
            EXPECT_NEAR(c[l], 0.5 * std::erfc(-u[l] / std::sqrt(2.0)), 1e-9) << u[l];
            const double pdf = std::exp(-0.5 * u[l] * u[l]) / std::sqrt(2.0 * M_PI);
            EXPECT_NEAR(p[l], pdf, 3e-13 * pdf) << u[l];
            EXPECT_NEAR(c[l], normalCdfPdf(u[l]).cdf, 1e-13) << u[l];
        }
        // The upper tail keeps its digits (relative error, not 1 − Φ's absolute one).
        for (int l = 0; l < 8; ++l) {
            const double tail = 0.5 * std::erfc(u[l] / std::sqrt(2.0));
            EXPECT_NEAR(n.upper[l], tail, 1e-8 * tail) << u[l];
        }
        // Float lanes: float rounding.
        lanes::Vf uf;
        for (int l = 0; l < lanes::kWidth; ++l) uf[l] = static_cast<float>(u[l % 8]);
        const NormalAt<lanes::Vf> nf = normalAt(uf, ExpNonPositiveOf{});
        for (int l = 0; l < lanes::kWidth; ++l)
            EXPECT_NEAR(nf.cdf[l], normalCdfPdf(uf[l]).cdf, 5e-7) << uf[l];
    }
}

TEST(FastMath, NormalCdfPdfNearErrorBounds) {
    // Measured over |u| < 5: |Φ error| 2.3e−7 (float rounding of the polynomial's Horner steps
    // near u = 0), φ relative 6.9e−7 and Φ(u < 0) relative 9.1e−7 (the rounding of u²/2,
    // ≤ 12.5·2^−24 = 7.5e−7 in e^(−u²/2), as for any float φ).
    double worstCdf = 0.0, worstPdf = 0.0, worstTail = 0.0;
    for (int i = 0; i < 200000; i += 16) {
        V16f u;
        for (int l = 0; l < 16; ++l)
            u[l] =
                -kNormalNearRange + 2.f * kNormalNearRange * static_cast<float>(i + l) / 200000.f;
        V16f c, p;
        normalCdfPdfNear(u, c, p);
        for (int l = 0; l < 16; ++l) {
            const double x = u[l];
            const double cdf = 0.5 * std::erfc(-x / std::sqrt(2.0));
            const double pdf = std::exp(-0.5 * x * x) / std::sqrt(2.0 * M_PI);
            worstCdf = std::max(worstCdf, std::fabs(c[l] - cdf));
            worstPdf = std::max(worstPdf, std::fabs(p[l] - pdf) / pdf);
            if (x < 0.0) worstTail = std::max(worstTail, std::fabs(c[l] - cdf) / cdf);
        }
    }
    std::printf("normalCdfPdfNear: |cdf error| %.2e, pdf relative %.2e, lower tail relative %.2e\n",
                worstCdf, worstPdf, worstTail);
    EXPECT_LT(worstCdf, 3e-7);
    EXPECT_LT(worstPdf, 1e-6);
    EXPECT_LT(worstTail, 1.5e-6);
}

TEST(FastMath, SumLanes) {
    V16f v;
    for (int l = 0; l < 16; ++l) v[l] = static_cast<float>(l + 1);
    EXPECT_EQ(sumLanes(v), 136.0);
}

}  // namespace
}  // namespace udvr::detail
