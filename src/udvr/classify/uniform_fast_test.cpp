// The fast uniform (BoxSplineFast: two exact boxes, a Gram–Charlier-corrected Gaussian remainder)
// against the exact box spline over random sums, TFs and points (issue 12: |ΔE| ≤ 1e−3), and
// its float and lane bodies against its double body.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "udvr/classify/classify_test_util.h"
#include "udvr/classify/expected_tf.h"
#include "udvr/classify/kernel_test_util.h"
#include "udvr/classify/model_families.h"
#include "udvr/classify/model_kernels.h"

namespace udvr {
namespace {

// Trilinear weights at a random point of the unit cell: inside, on faces, edges and corners.
void randomWeights(CounterRng& rng, double w[8]) {
    double f[3];
    for (double& x : f) {
        const double kind = rng.uniform();
        x = kind < 0.15  ? 0.0
            : kind < 0.3 ? 1.0
            : kind < 0.4 ? 1e-4 * rng.uniform()
                         : rng.uniform();
    }
    for (int k = 0; k < 8; ++k)
        w[k] =
            ((k & 1) ? f[0] : 1 - f[0]) * ((k & 2) ? f[1] : 1 - f[1]) * ((k & 4) ? f[2] : 1 - f[2]);
}

// Corner intervals: μ_c around 0, half-widths of ~1 spread over a decade, some 0 and some
// 1e−6 of the range.
void randomIntervals(CounterRng& rng, double lo[8], double hi[8]) {
    const double spread = rng.uniform() < 0.5 ? 0.0 : rng.uniform();
    for (int c = 0; c < 8; ++c) {
        const double mu = spread * rng.normal();
        const double kind = rng.uniform();
        const double h = kind < 0.1 ? 0.0 : kind < 0.2 ? 1e-6 : std::pow(10.0, rng.uniform() - 0.5);
        lo[c] = mu - h;
        hi[c] = mu + h;
    }
}

struct FastError {
    double worst = 0.0, worstAlpha = 0.0, sumSq = 0.0;
    long n = 0;
    double worstLanes = 0.0;  // the float lanes (the ray caster's body) against the exact kernel
    long nLanes = 0;
    long nonFinite = 0;  // (std::max would pass NaN over)
};

// The double body on 20 random points per random TF, and the float lane body on the first
// lanes::kWidth of them as one batch (lanes whose support is wider than kMaxFloatTotalOverPiece
// × the narrowest piece are left out: the kernel gives them the double body).
FastError fastAgainstExact(std::uint64_t seed, int cases) {
    using lanes::Vf;
    CounterRng rng(seed, 0, 0);
    FastError e;
    for (int trial = 0; trial < cases; ++trial) {
        const TransferFunction1D tf = testing::randomTf(rng, -3.0, 3.0);
        const TfPiecesStorage st(tf);
        Vf lof[8], hif[8], wf[8];
        double exactAt[lanes::kWidth][4];
        for (int p = 0; p < 20; ++p) {
            double w[8], lo[8], hi[8];
            randomWeights(rng, w);
            randomIntervals(rng, lo, hi);
            double exact[4], fast[4];
            expectedTfUniformSum(st.exact(), makeUniformSum(lo, hi, w, 6e-9), exact);
            expectedTfUniformFast<double>(st.exact(), makeBoxSplineFast<double>(lo, hi, w, 6e-6),
                                          6e-6, true, fast);
            for (int ch = 0; ch < 4; ++ch) {
                const double d = std::abs(fast[ch] - exact[ch]);
                e.nonFinite += !std::isfinite(fast[ch]);
                e.worst = std::max(e.worst, d);
                e.sumSq += d * d;
                ++e.n;
            }
            e.worstAlpha = std::max(e.worstAlpha, std::abs(fast[3] - exact[3]));
            if (p >= lanes::kWidth) continue;
            for (int c = 0; c < 8; ++c) {
                lof[c][p] = static_cast<float>(lo[c]);
                hif[c][p] = static_cast<float>(hi[c]);
                wf[c][p] = static_cast<float>(w[c]);
            }
            for (int ch = 0; ch < 4; ++ch) exactAt[p][ch] = exact[ch];
        }
        const BoxSplineFast<Vf> b = makeBoxSplineFast<Vf>(lof, hif, wf, 6e-6f);
        Vf got[4];
        expectedTfUniformFast<Vf>(st.fast(), b, 6e-6f, lanes::allTrue<Vf>(), got);
        for (int l = 0; l < lanes::kWidth; ++l) {
            for (int ch = 0; ch < 4; ++ch) e.nonFinite += !std::isfinite(got[ch][l]);
            if (b.total[l] > kMaxFloatTotalOverPiece * st.fast().narrowestPiece) continue;
            ++e.nLanes;
            for (int ch = 0; ch < 4; ++ch)
                e.worstLanes = std::max(e.worstLanes, std::abs(got[ch][l] - exactAt[l][ch]));
        }
    }
    return e;
}

TEST(UniformFast, MatchesTheExactBoxSpline) {
    // Measured (seed 12): max |d| 2.14e-4 (alpha 1.95e-4), rms 4.2e-6; float lanes 2.12e-4
    // (with the Edgeworth κ4² term, dropped since: 4.66e-4, rms 8.7e-6).
    const FastError e = fastAgainstExact(12, 1000);
    std::printf(
        "fast vs exact uniform over %ld values: max |d| %.2e (alpha %.2e), rms %.2e; "
        "float lanes (%ld samples) max |d| %.2e\n",
        e.n, e.worst, e.worstAlpha, std::sqrt(e.sumSq / static_cast<double>(e.n)), e.nLanes,
        e.worstLanes);
    EXPECT_EQ(e.nonFinite, 0);
    EXPECT_LE(e.worst, 1e-3);
    EXPECT_LE(e.worstLanes, 1e-3);
    EXPECT_GT(e.nLanes, 600 * lanes::kWidth);  // of 1000·kWidth (the rest too wide for float)
}

// Sums whose boxes are near the point-mass width (1e−6 of the range, 6e−6 here), about a TF
// breakpoint: all widths 10^−6.5 to 10^−4, or one box of width ~1 and the rest 0 or tiny. The
// floors of h1, h2 and σ were that width itself, which spread such sums (and moved X's mean:
// the floored box widens about its left end) away from E[p_0(X)]'s exact mean and variance:
// 0.26 off (seed 31), and 3e−3 in 1 case in 10⁶ of the test above. Now 1.2e−4 (measured).
// Sums of total ≤ the point-mass width are TF(mean) by design and left out.
TEST(UniformFast, SumsNearTheFloorsKeepTheirMeanAndVariance) {
    CounterRng rng(31, 0, 0);
    double worst = 0.0;
    long n = 0;
    for (int trial = 0; trial < 2000; ++trial) {
        const TransferFunction1D tf = testing::randomTf(rng, -3.0, 3.0);
        const TfPiecesStorage st(tf);
        const TfPieces<double>& x = st.exact();
        for (int p = 0; p < 20; ++p) {
            double w[8], lo[8], hi[8];
            randomWeights(rng, w);
            const int k = static_cast<int>(rng.uniform() * x.breakCount) % x.breakCount;
            const bool oneWide = p % 2 == 1;
            const int wide = static_cast<int>(rng.uniform() * 8) % 8;
            for (int c = 0; c < 8; ++c) {
                const double h = oneWide && c == wide ? std::pow(10.0, rng.uniform() - 0.5)
                                 : oneWide && c % 2 == 0
                                     ? 0.0
                                     : std::pow(10.0, -6.5 + 2.5 * rng.uniform());
                const double mu = x.at(kTfBound, k) + (oneWide ? 0.5 : 1e-4) * rng.normal();
                lo[c] = mu - h;
                hi[c] = mu + h;
            }
            const BoxSplineFast<double> b = makeBoxSplineFast<double>(lo, hi, w, 6e-6);
            if (b.total <= 6e-6) continue;  // a point mass TF(mean) by design (docs/models.md)
            ++n;
            double exact[4], fast[4];
            expectedTfUniformSum(x, makeUniformSum(lo, hi, w, 6e-9), exact);
            expectedTfUniformFast<double>(x, b, 6e-6, true, fast);
            for (int ch = 0; ch < 4; ++ch) {
                ASSERT_TRUE(std::isfinite(fast[ch]));
                worst = std::max(worst, std::abs(fast[ch] - exact[ch]));
            }
        }
    }
    std::printf("sums near the floors (%ld): max |d| %.2e\n", n, worst);
    EXPECT_LE(worst, 1e-3);
    EXPECT_GT(n, 30000);
}

TEST(UniformFast, PointMassesAndSingleBoxesAreExact) {
    CounterRng rng(5, 0, 0);
    for (int trial = 0; trial < 200; ++trial) {
        const TransferFunction1D tf = testing::randomTf(rng, -3.0, 3.0);
        const TfPiecesStorage st(tf);
        double w[8] = {}, lo[8] = {}, hi[8] = {};
        w[trial % 8] = 1.0;
        lo[trial % 8] = 3.0 * rng.normal();
        hi[trial % 8] = lo[trial % 8] + (trial % 2 ? 0.0 : 2.0 * rng.uniform());
        double exact[4], fast[4];
        expectedTfUniformSum(st.exact(), makeUniformSum(lo, hi, w, 6e-9), exact);
        expectedTfUniformFast<double>(st.exact(), makeBoxSplineFast<double>(lo, hi, w, 6e-6), 6e-6,
                                      true, fast);
        // One box: h2 and σ are the floor (6e−6), which moves E by < its width × slope.
        for (int ch = 0; ch < 4; ++ch) EXPECT_NEAR(fast[ch], exact[ch], 2e-5) << trial;
    }
}

TEST(UniformFast, LanesAndFloatMatchDouble) {
    CounterRng rng(77, 0, 0);
    for (int trial = 0; trial < 6; ++trial) {
        const ModelVolume m = testing::randomModel(rng, {5, 4, 6}, 8);
        const auto r = modelDataRange(m);
        const TransferFunction1D tf =
            testing::withFloatBreaks(testing::randomTf(rng, r.first, r.second));
        const TfPiecesStorage st(tf);
        for (bool minMax : {false, true}) {
            ClassifyOptions o;
            o.uniformMinMax = minMax;
            const ModelFamily& f = modelFamily(ModelKind::UniformFast);
            const AnyKernel any = f.makeKernel(m, st, o, f);
            const auto& k = std::get<UniformKernel>(any);
            const double worst = testing::worstLaneError(k, rng, m.grid.dims, "uniform-fast");
            EXPECT_LE(worst, 2e-5) << trial << " minmax " << minMax;
        }
    }
}

}  // namespace
}  // namespace udvr

namespace udvr {
namespace {
// Float against double of the fast body for supports `ratio` times the TF's narrowest piece
// (random step-free TFs with pieces ~1): the float error grows with the ratio.
double floatErrorAt(double ratio, std::uint64_t seed) {
    CounterRng rng(seed, 0, 0);
    double worst = 0.0;
    for (int trial = 0; trial < 200; ++trial) {
        TransferFunction1D tf;
        for (int i = 0; i < 12; ++i) {
            tf.opacityX.push_back(static_cast<float>(i + 0.5 * rng.uniform()));
            tf.opacity.push_back(rng.uniform());
            tf.colorX.push_back(static_cast<float>(i + 0.5 * rng.uniform()));
            tf.color.push_back({rng.uniform(), rng.uniform(), rng.uniform()});
        }
        std::sort(tf.opacityX.begin(), tf.opacityX.end());
        std::sort(tf.colorX.begin(), tf.colorX.end());
        const TfPiecesStorage st(tf);
        double w[8], lo[8], hi[8];
        float wf[8], lof[8], hif[8];
        randomWeights(rng, w);
        const double half = 0.5 * ratio * st.exact().narrowestPiece, mu = 12.0 * rng.uniform();
        for (int c = 0; c < 8; ++c) {
            const double h = half * (0.5 + rng.uniform());
            lo[c] = lof[c] = static_cast<float>(mu - h);
            hi[c] = hif[c] = static_cast<float>(mu + h);
            wf[c] = static_cast<float>(w[c]);
            w[c] = wf[c];
        }
        double want[4];
        float got[4];
        expectedTfUniformFast<double>(st.exact(), makeBoxSplineFast<double>(lo, hi, w, 1e-5), 1e-5,
                                      true, want);
        expectedTfUniformFast<float>(st.fast(), makeBoxSplineFast<float>(lof, hif, wf, 1e-5f),
                                     1e-5f, true, got);
        for (int ch = 0; ch < 4; ++ch) worst = std::max(worst, std::abs(got[ch] - want[ch]));
    }
    return worst;
}

TEST(UniformFast, FloatErrorGrowsWithTheSupportOverTheNarrowestPiece) {
    // Measured (seed 3): 1.2e−6 at ratio 1, 2.5e−6 at 128, 3.9e−5 at 512; wider float lanes
    // take the double body (kMaxFloatTotalOverPiece).
    for (double ratio : {1.0, 8.0, 32.0, 128.0, 512.0})
        std::printf("support / narrowest piece %5.0f: float error %.2e\n", ratio,
                    floatErrorAt(ratio, 3));
    EXPECT_LE(floatErrorAt(kMaxFloatTotalOverPiece, 4), 2e-5);
}
}  // namespace
}  // namespace udvr
