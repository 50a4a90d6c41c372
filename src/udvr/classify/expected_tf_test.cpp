// Closed forms against independent numerics: the box spline against direct numerical
// convolution, the Gaussian against quadrature; both to 1e−4 (SPEC §4).
#include "udvr/classify/expected_tf.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "udvr/classify/classify_test_util.h"

namespace udvr {
namespace {

// E[TF(shift + Σ h_i U_i)] by numerical convolution of the discretised densities on a grid of
// `cells` cells over the support: each U[0,h] becomes cell masses (exact overlap fractions), the
// boxes are convolved with running sums, TF is evaluated at cell centres.
void convolutionReference(const TransferFunction1D& tf, double shift, std::vector<double> h,
                          double out[4], int cells = 400000) {
    double total = 0;
    for (double x : h) total += x;
    const double d = total / cells;
    std::vector<double> p(1, 1.0);
    for (double w : h) {
        const int full = static_cast<int>(w / d);
        const double rest = (w - full * d) / w, unit = d / w;
        std::vector<double> k(static_cast<std::size_t>(full) + 1, unit);
        k[static_cast<std::size_t>(full)] = rest;
        std::vector<double> q(p.size() + k.size() - 1, 0.0);
        // q = p * k with k constant except its last entry: running window sums.
        std::vector<double> prefix(p.size() + 1, 0.0);
        for (std::size_t i = 0; i < p.size(); ++i) prefix[i + 1] = prefix[i] + p[i];
        for (std::size_t m = 0; m < q.size(); ++m) {
            const long hiI = std::min<long>(static_cast<long>(m), static_cast<long>(p.size()) - 1);
            const long loI = std::max<long>(0, static_cast<long>(m) - full + 1);
            if (hiI >= loI) q[m] += unit * (prefix[hiI + 1] - prefix[loI]);
            const long j = static_cast<long>(m) - full;
            if (j >= 0 && j < static_cast<long>(p.size())) q[m] += rest * p[j];
        }
        p.swap(q);
    }
    for (int ch = 0; ch < 4; ++ch) out[ch] = 0;
    const double n = static_cast<double>(h.size());
    for (std::size_t m = 0; m < p.size(); ++m) {
        const Rgba c = tf.classify(shift + (static_cast<double>(m) + 0.5 * n) * d);
        out[0] += p[m] * c.r, out[1] += p[m] * c.g, out[2] += p[m] * c.b, out[3] += p[m] * c.a;
    }
}

UniformSum sumOf(double shift, const std::vector<double>& widths) {
    double lo[8] = {}, hi[8] = {};
    float w[8] = {};
    for (std::size_t i = 0; i < widths.size(); ++i) {
        lo[i] = i == 0 ? shift : 0.0;
        hi[i] = lo[i] + widths[i];
        w[i] = 1.f;
    }
    return makeUniformSum(lo, hi, w, 0.0);
}

TEST(ExpectedTfUniform, MatchesNumericalConvolution) {
    CounterRng rng(31, 0, 0);
    for (int trial = 0; trial < 12; ++trial) {
        const TransferFunction1D tf = testing::randomTf(rng, 0.0, 1.0);
        const TfTableStorage st(tf);
        const int n = 1 + trial % 8;
        std::vector<double> h;
        for (int i = 0; i < n; ++i)  // widths over three orders of magnitude
            h.push_back(0.4 * std::pow(10.0, -2.5 * rng.uniform()));
        const double shift = -0.2 + 0.8 * rng.uniform();
        double ref[4], got[4];
        convolutionReference(tf, shift, h, ref);
        expectedTfUniformSum(st.table(), sumOf(shift, h), got);
        for (int ch = 0; ch < 4; ++ch) EXPECT_NEAR(got[ch], ref[ch], 1e-4) << trial << " " << ch;
    }
}

TEST(ExpectedTfUniform, BreaksWithoutChangeAreSkippedExactly) {
    // Colour points inside a stretch where α = 0 change nothing in (α·c, α): the fast path that
    // skips them must agree with the numerical convolution, with and without such points inside
    // the support, for 1 … 8 terms.
    TransferFunction1D tf;
    tf.colorX = {0.0, 0.3, 0.45, 0.5, 1.0};
    tf.color = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 0}, {0, 1, 1}};
    tf.opacityX = {0.0, 0.2, 0.25, 0.6, 0.7, 1.0};
    tf.opacity = {0.5, 0.0, 0.0, 0.0, 0.8, 0.3};
    const TfTableStorage st(tf);
    CounterRng rng(33, 0, 0);
    for (int n = 1; n <= 8; ++n) {
        for (double shift : {0.27, 0.1, 0.5}) {
            std::vector<double> h;
            for (int i = 0; i < n; ++i) h.push_back((0.05 + 0.3 * rng.uniform()) / n);
            double ref[4], got[4];
            convolutionReference(tf, shift, h, ref);
            expectedTfUniformSum(st.table(), sumOf(shift, h), got);
            for (int ch = 0; ch < 4; ++ch) EXPECT_NEAR(got[ch], ref[ch], 1e-4) << n << " " << ch;
        }
    }
    // A support inside the α = 0 stretch: exactly zero, no tail evaluated.
    double got[4];
    expectedTfUniformSum(st.table(), sumOf(0.26, {0.1, 0.1, 0.1}), got);
    for (int ch = 0; ch < 4; ++ch) EXPECT_EQ(got[ch], 0.0);
}

TEST(ExpectedTfUniform, StableForWildlyDifferentWidths) {
    // Widths from 1 down to 1e-10: the result must tend continuously to the limit in which the
    // tiny terms are point masses at their means.
    CounterRng rng(32, 0, 0);
    for (int trial = 0; trial < 20; ++trial) {
        const TransferFunction1D tf = testing::randomTf(rng, 0.0, 2.0);
        const TfTableStorage st(tf);
        std::vector<double> big = {0.3 + rng.uniform(), 0.1 + 0.5 * rng.uniform()};
        const double shift = -0.5 + rng.uniform();
        for (double tiny : {1e-6, 1e-8, 1e-10}) {
            std::vector<double> h = big;
            double shifted = shift;
            for (int i = 0; i < 6; ++i) {
                h.push_back(tiny * (1 + i));
                shifted += 0.5 * tiny * (1 + i);
            }
            double a[4], b[4];
            expectedTfUniformSum(st.table(), sumOf(shift, h), a);
            expectedTfUniformSum(st.table(), sumOf(shifted, big), b);
            for (int ch = 0; ch < 4; ++ch) EXPECT_NEAR(a[ch], b[ch], 1e-5 + 100 * tiny);
        }
    }
}

TEST(ExpectedTfUniform, SupportWiderThanTheTfIsClamped) {
    TransferFunction1D tf;
    tf.colorX = {0.0, 1.0};
    tf.color = {{1, 0, 0}, {0, 0, 1}};
    tf.opacityX = {0.0, 1.0};
    tf.opacity = {0.0, 1.0};
    const TfTableStorage st(tf);
    // U[-10, 10]: α = 0 below 0, x on [0,1], 1 above: E = (0.5 + 9)/20.
    double got[4];
    expectedTfUniformSum(st.table(), sumOf(-10.0, {20.0}), got);
    EXPECT_NEAR(got[3], 9.5 / 20.0, 1e-12);
}

// ∫ TF·φ by composite Simpson on each TF piece (split at every breakpoint) over μ ± 12σ.
void gaussianQuadrature(const TransferFunction1D& tf, double mu, double sigma, double out[4]) {
    std::vector<double> cuts = {mu - 12 * sigma, mu + 12 * sigma};
    for (double x : tf.colorX) cuts.push_back(x);
    for (double x : tf.opacityX) cuts.push_back(x);
    std::sort(cuts.begin(), cuts.end());
    for (int ch = 0; ch < 4; ++ch) out[ch] = 0;
    for (std::size_t i = 0; i + 1 < cuts.size(); ++i) {
        const double a = std::max(cuts[i], mu - 12 * sigma),
                     b = std::min(cuts[i + 1], mu + 12 * sigma);
        if (!(b > a)) continue;
        const int n = 2000;
        const double h = (b - a) / n;
        for (int k = 0; k <= n; ++k) {
            // Points strictly inside the piece so steps at its ends take the piece's side.
            const double x =
                k == 0 ? a + 1e-12 * (b - a) : (k == n ? b - 1e-12 * (b - a) : a + k * h);
            const double wgt = (k == 0 || k == n) ? 1 : (k % 2 ? 4 : 2);
            const double z = (x - mu) / sigma;
            const double pdf = std::exp(-0.5 * z * z) / (sigma * std::sqrt(2 * M_PI));
            const Rgba c = tf.classify(x);
            const double f = wgt * h / 3 * pdf;
            out[0] += f * c.r, out[1] += f * c.g, out[2] += f * c.b, out[3] += f * c.a;
        }
    }
}

TEST(ExpectedTfGaussian, MatchesQuadrature) {
    CounterRng rng(41, 0, 0);
    for (int trial = 0; trial < 40; ++trial) {
        const TransferFunction1D tf = testing::randomTf(rng, 0.0, 1.0);
        const TfTableStorage st(tf);
        const double mu = -0.3 + 1.6 * rng.uniform();
        const double sigma =
            std::pow(10.0, -3.0 + 3.5 * rng.uniform());  // 1e-3 … 3: wider than the TF
        double ref[4], got[4];
        gaussianQuadrature(tf, mu, sigma, ref);
        expectedTfGaussian(st.table(), mu, sigma, got);
        for (int ch = 0; ch < 4; ++ch) EXPECT_NEAR(got[ch], ref[ch], 1e-5) << trial;
    }
}

TEST(ExpectedTfGaussian, ZeroSigmaIsThePointValue) {
    CounterRng rng(42, 0, 0);
    const TransferFunction1D tf = testing::randomTf(rng, 0.0, 1.0);
    const TfTableStorage st(tf);
    double got[4];
    expectedTfGaussian(st.table(), 0.37, 0.0, got);
    EXPECT_NEAR(got[3], tf.opacityAt(0.37), 1e-12);
}

}  // namespace
}  // namespace udvr
