// The TF pieces (SPEC §4) against TransferFunction1D's own evaluator, interval means against
// Gauss–Legendre quadrature on the TF's linear stretches, and the float and lane views against
// the double one.
#include "udvr/classify/tf_pieces.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "udvr/classify/classify_test_util.h"
#include "udvr/classify/expected_tf.h"
#include "udvr/classify/tf_presets.h"
#include "udvr/data/synthetic.h"

namespace udvr {
namespace {

// TF(x) = (α·r, α·g, α·b, α) in double from the TF's own evaluator.
void reference(const TransferFunction1D& tf, double x, double out[4]) {
    const double a = tf.opacityAt(x);
    const auto c = tf.colorAt(x);
    for (int ch = 0; ch < 3; ++ch) out[ch] = a * c[ch];
    out[3] = a;
}

// The distinct breakpoints of a TF, ascending (the definition of the pieces).
std::vector<double> breakpoints(const TransferFunction1D& tf) {
    std::vector<double> u = tf.colorX;
    u.insert(u.end(), tf.opacityX.begin(), tf.opacityX.end());
    std::sort(u.begin(), u.end());
    u.erase(std::unique(u.begin(), u.end()), u.end());
    return u;
}

// The breakpoints the pieces keep: those of `breakpoints` except where the TF is 0 on both sides
// (TfPiecesStorage merges zero pieces), judged from the TF's own evaluator at three interior
// points of each neighbouring stretch (each channel is a polynomial of degree ≤ 2 there); at
// least the last one stays.
std::vector<double> visibleBreakpoints(const TransferFunction1D& tf) {
    const std::vector<double> u = breakpoints(tf);
    const auto zeroOn = [&](double lo, double hi) {  // open interval, ends may be ±1 beyond u
        for (double t : {0.25, 0.5, 0.75}) {
            double v[4];
            reference(tf, lo + t * (hi - lo), v);
            for (double c : v)
                if (c != 0.0) return false;
        }
        return true;
    };
    std::vector<double> kept;
    for (std::size_t i = 0; i < u.size(); ++i) {
        const double lo = i > 0 ? u[i - 1] : u[0] - 1.0;
        const double hi = i + 1 < u.size() ? u[i + 1] : u[i] + 1.0;
        if (!(zeroOn(lo, u[i]) && zeroOn(u[i], hi))) kept.push_back(u[i]);
    }
    if (kept.empty()) kept.push_back(u.back());
    return kept;
}

// Piece of x by counting: the number of breakpoints ≤ x (NaN: 0).
int countPiece(const std::vector<double>& u, double x) {
    int k = 0;
    for (double b : u) k += x >= b ? 1 : 0;
    return k;
}

// Mean of TF over [lo, hi] by 3-point Gauss–Legendre on each stretch between consecutive
// breakpoints inside [lo, hi]: every channel is a polynomial of degree ≤ 2 there, which the rule
// integrates exactly, and its nodes are interior, so steps at the stretch ends never matter.
void quadratureMean(const TransferFunction1D& tf, double lo, double hi, double out[4]) {
    std::vector<double> cuts = {lo, hi};
    for (double b : breakpoints(tf))
        if (b > lo && b < hi) cuts.push_back(b);
    std::sort(cuts.begin(), cuts.end());
    const double node = std::sqrt(0.6), w[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
    for (int ch = 0; ch < 4; ++ch) out[ch] = 0;
    for (std::size_t i = 0; i + 1 < cuts.size(); ++i) {
        const double a = cuts[i], b = cuts[i + 1], mid = 0.5 * (a + b), half = 0.5 * (b - a);
        const double xs[3] = {mid - node * half, mid, mid + node * half};
        for (int n = 0; n < 3; ++n) {
            double v[4];
            reference(tf, xs[n], v);
            for (int ch = 0; ch < 4; ++ch) out[ch] += w[n] * half * v[ch];
        }
    }
    for (int ch = 0; ch < 4; ++ch) out[ch] /= hi - lo;
}

// A TF with `n` opacity points (0.5 apart, some steps) and a two-point colour ramp: n ≥ 32
// breakpoints give stride > 32 (lane lookups are gathers).
TransferFunction1D manyBreaksTf(int n) {
    TransferFunction1D tf;
    for (int i = 0; i < n; ++i) {
        tf.opacityX.push_back(i % 5 == 4 ? tf.opacityX.back() : i * 0.5);  // steps
        tf.opacity.push_back(i % 3 == 0 ? 0.0 : 0.1 * (i % 7) + 0.05);
    }
    tf.colorX = {0.0, n * 0.5 - 0.5};
    tf.color = {{1.0, 0.0, 0.2}, {0.0, 0.6, 1.0}};
    return tf;
}

TEST(TfPieces, ExactMatchesTransferFunctionEverywhere) {
    CounterRng rng(7, 0, 0);
    for (int trial = 0; trial < 50; ++trial) {
        const TransferFunction1D tf = testing::randomTf(rng, -1.0, 2.0);
        const TfPiecesStorage st(tf, trial % 2 ? 4096 : 3);  // few buckets exercise the walk
        const TfPieces<double>& t = st.exact();
        const std::vector<double> u = visibleBreakpoints(tf);
        ASSERT_EQ(t.breakCount, static_cast<int>(u.size()));
        std::vector<double> xs = {-5.0, 7.0, -1e300, 1e300};
        for (double x : breakpoints(tf)) {  // breakpoints and steps exactly, and their neighbours
            xs.push_back(x);
            xs.push_back(std::nextafter(x, -1e300));
            xs.push_back(std::nextafter(x, 1e300));
        }
        for (int i = 0; i < 400; ++i) xs.push_back(-1.5 + 4.0 * rng.uniform());
        for (double x : xs) {
            ASSERT_EQ(t.pieceOf(x), countPiece(u, x)) << x;
            double v[4], want[4];
            tfAt<double>(t, x, v);
            reference(tf, x, want);
            // Lines a0 + s·(x − origin) against the TF's own interpolation: double rounding.
            for (int ch = 0; ch < 4; ++ch) EXPECT_NEAR(v[ch], want[ch], 1e-12) << x << " " << ch;
        }
        const double nan = std::numeric_limits<double>::quiet_NaN();
        EXPECT_EQ(t.pieceOf(nan), 0);
    }
}

// The tangle TF's colour points at −2 and 1.5 and its ends −6.95 and 35.24 sit where α = 0 on
// both sides: its 13 breakpoints make 9 pieces' bounds, and the TF is unchanged everywhere.
TEST(TfPieces, ZeroStretchesMerge) {
    const TransferFunction1D tf = tangleTransferFunction();
    ASSERT_EQ(breakpoints(tf).size(), 13u);
    const TfPiecesStorage st(tf);
    const std::vector<double> want = {-5.5, -4.5, -3.5, -0.6, 0.0, 0.6, 2.4, 3.0, 3.6};
    ASSERT_EQ(st.exact().breakCount, static_cast<int>(want.size()));
    for (std::size_t k = 0; k < want.size(); ++k)
        EXPECT_EQ(st.exact().at(kTfBound, static_cast<int>(k)), want[k]);
    for (int i = 0; i <= 5000; ++i) {
        const double x = -8.0 + 45.0 * i / 5000.0;
        double v[4], ref[4];
        tfAt<double>(st.exact(), x, v);
        reference(tf, x, ref);
        for (int ch = 0; ch < 4; ++ch) EXPECT_NEAR(v[ch], ref[ch], 1e-12) << x;
    }
    // ∫ over the whole TF from the prefix sums against quadrature over the original stretches.
    double mean[4], ref[4];
    tfMeanOver<double>(st.exact(), -7.0, 36.0, st.exact().pieceOf(-7.0), st.exact().pieceOf(36.0),
                       mean);
    quadratureMean(tf, -7.0, 36.0, ref);
    for (int ch = 0; ch < 4; ++ch) EXPECT_NEAR(mean[ch], ref[ch], 1e-13);
    // A TF that is 0 everywhere keeps one bound.
    TransferFunction1D clear = tf;
    for (double& a : clear.opacity) a = 0.0;
    EXPECT_EQ(TfPiecesStorage(clear).exact().breakCount, 1);
}

TEST(TfPieces, StepIsRightContinuous) {
    TransferFunction1D tf;
    tf.colorX = {0.0, 1.0};
    tf.color = {{1, 1, 1}, {1, 1, 1}};
    tf.opacityX = {0.0, 0.5, 0.5, 1.0};
    tf.opacity = {0.0, 0.2, 0.8, 0.8};
    const TfPiecesStorage st(tf);
    double v[4];
    tfAt<double>(st.exact(), 0.5, v);
    EXPECT_DOUBLE_EQ(v[3], 0.8);
    tfAt<double>(st.exact(), std::nextafter(0.5, 0.0), v);
    EXPECT_NEAR(v[3], 0.2, 1e-12);
    // The float view: 0.5 is a float, so the step sits at the same x.
    float f[4];
    tfAt<float>(st.fast(), 0.5f, f);
    EXPECT_FLOAT_EQ(f[3], 0.8f);
    tfAt<float>(st.fast(), std::nextafter(0.5f, 0.f), f);
    EXPECT_NEAR(f[3], 0.2f, 1e-6);
}

TEST(TfPieces, MeanOverMatchesQuadrature) {
    CounterRng rng(8, 0, 0);
    for (int trial = 0; trial < 40; ++trial) {
        const TransferFunction1D tf = testing::randomTf(rng, 0.0, 1.0);
        const TfPiecesStorage st(tf);
        const TfPieces<double>& t = st.exact();
        for (int i = 0; i < 20; ++i) {
            double lo = -0.3 + 1.6 * rng.uniform(), hi = -0.3 + 1.6 * rng.uniform();
            if (lo > hi) std::swap(lo, hi);
            if (i == 0) lo = -1e6;  // far into the clamped ends
            if (i == 1) hi = 1e6;
            double v[4], want[4];
            tfMeanOver<double>(t, lo, hi, t.pieceOf(lo), t.pieceOf(hi), v);
            quadratureMean(tf, lo, hi, want);
            // Exact quadrature of the same polynomials: double rounding (×|x| ≤ 1e6 at the ends).
            for (int ch = 0; ch < 4; ++ch) EXPECT_NEAR(v[ch], want[ch], 1e-10) << trial << " " << i;
        }
    }
}

TEST(TfPieces, TinyIntervalsAcrossBreakpointsStayExact) {
    TransferFunction1D tf;
    tf.colorX = {0.0, 1000.0};
    tf.color = {{0, 0, 0}, {1, 1, 1}};
    tf.opacityX = {0.0, 500.0, 500.0, 1000.0};
    tf.opacity = {0.0, 0.0, 1.0, 1.0};
    const TfPiecesStorage st(tf);
    const TfPieces<double>& t = st.exact();
    const double eps = 1e-11;
    const double lo = 500.0 - eps, hi = 500.0 + 3 * eps;
    double v[4];
    tfMeanOver<double>(t, lo, hi, t.pieceOf(lo), t.pieceOf(hi), v);
    // α = 0 below 500 and 1 from 500 on: the fraction of the (rounded) interval above 500; the
    // colour c = x/1000 is 0.5 there to 1e−14.
    const double above = (hi - 500.0) / (hi - lo);
    EXPECT_NEAR(v[3], above, 1e-12);
    EXPECT_NEAR(v[0], 0.5 * above, 1e-12);
    tfMeanOver<double>(t, 500.0, 500.0, t.pieceOf(500.0), t.pieceOf(500.0), v);  // TF(hi)
    EXPECT_DOUBLE_EQ(v[3], 1.0);
    tfMeanOver<double>(t, 600.0, 400.0, t.pieceOf(600.0), t.pieceOf(400.0), v);  // hi < lo
    EXPECT_DOUBLE_EQ(v[3], 0.0);
    // The float view on an interval of a few ulps across the step (the prefix sums are a
    // float pair, the partial pieces float): within float rounding of the exact fraction.
    const TfPieces<float>& f = st.fast();
    const float flo = std::nextafter(500.f, 0.f),
                fhi = std::nextafter(std::nextafter(500.f, 1e4f), 1e4f);
    float fv[4];
    tfMeanOver<float>(f, flo, fhi, f.pieceOf(flo), f.pieceOf(fhi), fv);
    const double fAbove = (static_cast<double>(fhi) - 500.0) / (static_cast<double>(fhi) - flo);
    EXPECT_NEAR(fv[3], fAbove, 1e-6);
}

TEST(TfPieces, ConstantAndSinglePointTf) {
    TransferFunction1D tf;
    tf.colorX = {3.0};
    tf.color = {{0.5, 0.25, 1.0}};
    tf.opacityX = {3.0};
    tf.opacity = {0.5};
    const TfPiecesStorage st(tf);
    ASSERT_EQ(st.exact().breakCount, 1);
    double v[4];
    for (double x : {-1e9, 3.0, 1e9}) {
        tfAt<double>(st.exact(), x, v);
        EXPECT_DOUBLE_EQ(v[0], 0.25);
        EXPECT_DOUBLE_EQ(v[3], 0.5);
    }
    tfMeanOver<double>(st.exact(), -10.0, 10.0, st.exact().pieceOf(-10.0), st.exact().pieceOf(10.0),
                       v);
    EXPECT_NEAR(v[2], 0.5, 1e-12);
    // Float and lane views of the one-breakpoint TF (no buckets).
    const float xs[16] = {-1e9f, 3.f, 1e9f, 2.9999f, 3.0001f, -1e30f, 1e30f, 0.f,
                          1.f,   2.f, 4.f,  5.f,     6.f,     7.f,    8.f,   9.f};
    for (int i = 0; i < 16; i += lanes::kWidth) {
        const lanes::Vf x = lanes::load(xs + i);
        lanes::Vf out[4];
        tfAt<lanes::Vf>(st.fast(), x, out);
        for (int l = 0; l < lanes::kWidth; ++l) {
            EXPECT_EQ(out[0][l], 0.25f) << x[l];
            EXPECT_EQ(out[3][l], 0.5f) << x[l];
        }
        tfMeanOver<lanes::Vf>(st.fast(), x, x + 1.f, st.fast().pieceOf(x),
                              st.fast().pieceOf(x + 1.f), out);
        for (int l = 0; l < lanes::kWidth; ++l) EXPECT_EQ(out[2][l], 0.5f) << x[l];
    }
}

// The float view (scalar and lanes) against the double view, on TFs whose breakpoints are
// floats. Tolerance: the float pieces are the exact pieces with coefficients rounded to float
// (relative 6e−8) about float origins, evaluated in float; for TF values in [0, 1] a point
// value is off by a few float roundings of |α·c| ≤ 1, and a mean over [lo, hi] adds the
// rounding of the prefix-sum pair and of the 1/(hi − lo) scaling. Measured worst: 1.6e−7 over
// both tests (x up to 1000, TF pieces as narrow as 1e−3).
constexpr double kFloatTol = 1e-6;

// Checks of one view V (TfPieces<float, 0> or the sized one) on kWidth x at a time.
template <class View>
void expectLanesMatchDouble(const View& view, const TfPieces<float>& scalar,
                            const TfPieces<double>& exact, const std::vector<float>& xs,
                            CounterRng& rng) {
    for (std::size_t i = 0; i + lanes::kWidth <= xs.size(); i += lanes::kWidth) {
        const lanes::Vf x = lanes::load(&xs[i]);
        // A partner per lane: near x (often inside one piece), or anywhere (spanning pieces).
        lanes::Vf y;
        for (int l = 0; l < lanes::kWidth; ++l)
            y[l] = l % 3 == 0 ? x[l] + static_cast<float>(1e-3 * rng.uniform())
                              : static_cast<float>(xs[(i + 7 * l) % xs.size()]);
        const lanes::Vf lo = lanes::min(x, y), hi = lanes::max(x, y);
        const lanes::Vi k = view.pieceOf(x);
        lanes::Vf at[4], mean[4];
        tfAt<lanes::Vf>(view, x, at);
        tfMeanOver<lanes::Vf>(view, lo, hi, view.pieceOf(lo), view.pieceOf(hi), mean);
        for (int l = 0; l < lanes::kWidth; ++l) {
            const float xl = x[l];
            // Piece: lanes (binary search) = scalar float (buckets) = the double count.
            ASSERT_EQ(k[l], scalar.pieceOf(xl)) << xl;
            if (std::isnan(xl)) {
                EXPECT_EQ(k[l], 0);
                continue;
            }
            ASSERT_EQ(k[l], exact.pieceOf(static_cast<double>(xl))) << xl;
            // Values at finite x only: at ±inf the lines give 0·∞ (data is finite: the readers
            // reject Inf).
            if (std::isinf(xl)) continue;
            double want[4];
            tfAt<double>(exact, static_cast<double>(xl), want);
            float f[4];
            tfAt<float>(scalar, xl, f);
            for (int ch = 0; ch < 4; ++ch) {
                EXPECT_NEAR(at[ch][l], want[ch], kFloatTol) << xl << " " << ch;
                EXPECT_NEAR(f[ch], want[ch], kFloatTol) << xl << " " << ch;
            }
            // Means over finite intervals of data-like values (|x| ≤ 1e6).
            const double dlo = lo[l], dhi = hi[l];
            if (!(std::abs(dlo) <= 1e6 && std::abs(dhi) <= 1e6)) continue;
            double wantMean[4];
            tfMeanOver<double>(exact, dlo, dhi, exact.pieceOf(dlo), exact.pieceOf(dhi), wantMean);
            float fm[4];
            tfMeanOver<float>(scalar, lo[l], hi[l], scalar.pieceOf(lo[l]), scalar.pieceOf(hi[l]),
                              fm);
            for (int ch = 0; ch < 4; ++ch) {
                EXPECT_NEAR(mean[ch][l], wantMean[ch], kFloatTol) << dlo << " " << dhi << " " << ch;
                EXPECT_NEAR(fm[ch], wantMean[ch], kFloatTol) << dlo << " " << dhi << " " << ch;
            }
        }
    }
}

// x values for a TF: every breakpoint and its float neighbours, random points over and beyond
// the TF's range, ±inf, ±huge and NaN; a multiple of kWidth.
std::vector<float> probePoints(const TransferFunction1D& tf, CounterRng& rng, double lo,
                               double hi) {
    std::vector<float> xs = {-INFINITY, INFINITY, -1e30f, 1e30f,
                             std::numeric_limits<float>::quiet_NaN()};
    for (double b : breakpoints(tf)) {
        const float f = static_cast<float>(b);
        xs.insert(xs.end(), {f, std::nextafter(f, -INFINITY), std::nextafter(f, INFINITY)});
    }
    while (xs.size() < 400 || xs.size() % lanes::kWidth)
        xs.push_back(static_cast<float>(lo + (hi - lo) * rng.uniform()));
    return xs;
}

TEST(TfPieces, FloatAndLaneViewsMatchTheDoubleView) {
    CounterRng rng(9, 0, 0);
    for (int trial = 0; trial < 40; ++trial) {
        const double lo = trial % 4 == 3 ? 995.0 : -1.0, hi = lo + 3.0;
        const TransferFunction1D tf = testing::withFloatBreaks(testing::randomTf(rng, lo, hi));
        const TfPiecesStorage st(tf, trial % 2 ? 4096 : 3);
        ASSERT_EQ(st.fast().stride, kTfSmall);  // ≤ 18 breakpoints
        const std::vector<float> xs = probePoints(tf, rng, lo - 0.5, hi + 0.5);
        expectLanesMatchDouble(st.fast(), st.fast(), st.exact(), xs, rng);
        expectLanesMatchDouble(st.fast().sized<kTfSmall>(), st.fast(), st.exact(), xs, rng);
    }
}

// More than 31 breakpoints: columns longer than 32 (the binary search takes more steps and the
// lookups are gathers); 16 … 31 still fit 32-entry columns (register permutes on AVX-512).
TEST(TfPieces, ManyBreakpointsTakeGatherLookups) {
    CounterRng rng(10, 0, 0);
    for (int n : {16, 17, 31, 32, 33, 40, 64, 100, 300}) {
        const TransferFunction1D tf = manyBreaksTf(n);
        const TfPiecesStorage st(tf);
        const int breaks = static_cast<int>(visibleBreakpoints(tf).size());
        ASSERT_EQ(st.fast().breakCount, breaks);
        EXPECT_EQ(st.fast().stride == kTfSmall, breaks <= 31) << n;
        EXPECT_GE(st.fast().stride, breaks + 1);
        const std::vector<float> xs = probePoints(tf, rng, -1.0, 0.5 * n + 1.0);
        expectLanesMatchDouble(st.fast(), st.fast(), st.exact(), xs, rng);
        if (st.fast().stride == kTfSmall)
            expectLanesMatchDouble(st.fast().sized<kTfSmall>(), st.fast(), st.exact(), xs, rng);
    }
}

}  // namespace
}  // namespace udvr
