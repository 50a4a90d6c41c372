// Closed forms against independent numerics: the box spline against direct numerical
// convolution, the Gaussian against quadrature; both to 1e−4 (SPEC §4).
#include "udvr/classify/expected_tf.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "udvr/classify/classify_test_util.h"
#include "udvr/classify/tf_presets.h"
#include "udvr/data/synthetic.h"

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
    double lo[8] = {}, hi[8] = {}, w[8] = {};
    for (std::size_t i = 0; i < widths.size(); ++i) {
        lo[i] = i == 0 ? shift : 0.0;
        hi[i] = lo[i] + widths[i];
        w[i] = 1.0;
    }
    return makeUniformSum(lo, hi, w, 0.0);
}

TEST(ExpectedTfUniform, MatchesNumericalConvolution) {
    CounterRng rng(31, 0, 0);
    for (int trial = 0; trial < 12; ++trial) {
        const TransferFunction1D tf = testing::randomTf(rng, 0.0, 1.0);
        const TfPiecesStorage st(tf);
        const int n = 1 + trial % 8;
        std::vector<double> h;
        for (int i = 0; i < n; ++i)  // widths over three orders of magnitude
            h.push_back(0.4 * std::pow(10.0, -2.5 * rng.uniform()));
        const double shift = -0.2 + 0.8 * rng.uniform();
        double ref[4], got[4];
        convolutionReference(tf, shift, h, ref);
        expectedTfUniformSum(st.exact(), sumOf(shift, h), got);
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
    const TfPiecesStorage st(tf);
    CounterRng rng(33, 0, 0);
    for (int n = 1; n <= 8; ++n) {
        for (double shift : {0.27, 0.1, 0.5}) {
            std::vector<double> h;
            for (int i = 0; i < n; ++i) h.push_back((0.05 + 0.3 * rng.uniform()) / n);
            double ref[4], got[4];
            convolutionReference(tf, shift, h, ref);
            expectedTfUniformSum(st.exact(), sumOf(shift, h), got);
            for (int ch = 0; ch < 4; ++ch) EXPECT_NEAR(got[ch], ref[ch], 1e-4) << n << " " << ch;
        }
    }
    // A support inside the α = 0 stretch: exactly zero, no tail evaluated.
    double got[4];
    expectedTfUniformSum(st.exact(), sumOf(0.26, {0.1, 0.1, 0.1}), got);
    for (int ch = 0; ch < 4; ++ch) EXPECT_EQ(got[ch], 0.0);
}

TEST(ExpectedTfUniform, StableForWildlyDifferentWidths) {
    // Widths from 1 down to 1e-10: the result must tend continuously to the limit in which the
    // tiny terms are point masses at their means.
    CounterRng rng(32, 0, 0);
    for (int trial = 0; trial < 20; ++trial) {
        const TransferFunction1D tf = testing::randomTf(rng, 0.0, 2.0);
        const TfPiecesStorage st(tf);
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
            expectedTfUniformSum(st.exact(), sumOf(shift, h), a);
            expectedTfUniformSum(st.exact(), sumOf(shifted, big), b);
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
    const TfPiecesStorage st(tf);
    // U[-10, 10]: α = 0 below 0, x on [0,1], 1 above: E = (0.5 + 9)/20.
    double got[4];
    expectedTfUniformSum(st.exact(), sumOf(-10.0, {20.0}), got);
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
        const TfPiecesStorage st(tf);
        const double mu = -0.3 + 1.6 * rng.uniform();
        const double sigma =
            std::pow(10.0, -3.0 + 3.5 * rng.uniform());  // 1e-3 … 3: wider than the TF
        double ref[4], got[4];
        gaussianQuadrature(tf, mu, sigma, ref);
        expectedTfGaussian<double>(st.exact(), mu, sigma, true, got);
        for (int ch = 0; ch < 4; ++ch) EXPECT_NEAR(got[ch], ref[ch], 1e-5) << trial;
    }
}

TEST(ExpectedTfGaussian, ZeroSigmaIsThePointValue) {
    CounterRng rng(42, 0, 0);
    for (int trial = 0; trial < 20; ++trial) {
        const TransferFunction1D tf = testing::randomTf(rng, 0.0, 1.0);
        const TfPiecesStorage st(tf);
        // σ = 0, and σ < 0 or NaN (treated as 0), at random μ and at every breakpoint.
        std::vector<double> mus = {-3.0, 0.37, 4.0};
        for (double x : tf.opacityX) mus.push_back(x);
        for (double x : tf.colorX) mus.push_back(x);
        for (double mu : mus)
            for (double sigma : {0.0, -1.0, std::nan("")}) {
                double got[4];
                expectedTfGaussian<double>(st.exact(), mu, sigma, true, got);
                const double a = tf.opacityAt(mu);
                const auto c = tf.colorAt(mu);
                EXPECT_NEAR(got[3], a, 1e-12) << mu << " " << sigma;
                for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(got[ch], a * c[ch], 1e-12) << mu;
            }
    }
}

// TFs for the float bodies: random ones, the tangle's, the tangle's with a step, and one with 40
// breakpoints (stride 64: lane lookups are gathers), each also moved to |x| ~ 1000; breakpoints
// rounded to float.
std::vector<TransferFunction1D> floatBodyTfs(CounterRng& rng) {
    std::vector<TransferFunction1D> tfs;
    for (int i = 0; i < 12; ++i) tfs.push_back(testing::randomTf(rng, -1.0, 2.0));
    tfs.push_back(tangleTransferFunction());
    TransferFunction1D stepped = tangleTransferFunction();
    stepped.opacityX = {-3.0, -1.0, 0.1, 0.1, 2.0, 5.0};
    stepped.opacity = {0.2, 0.7, 0.1, 0.9, 0.4, 0.0};
    tfs.push_back(stepped);
    TransferFunction1D many;
    for (int i = 0; i < 40; ++i) {
        many.opacityX.push_back(-5.0 + 0.25 * i);
        many.opacity.push_back(i % 3 == 0 ? 0.0 : 0.1 * (i % 7) + 0.05);
    }
    many.colorX = {-5.0, 5.0};
    many.color = {{1.0, 0.0, 0.2}, {0.0, 0.6, 1.0}};
    tfs.push_back(many);
    const std::size_t n = tfs.size();
    for (std::size_t i = 0; i < n; i += 3) {  // a few far from 0
        TransferFunction1D far = tfs[i];
        for (double& x : far.colorX) x += 1000.0;
        for (double& x : far.opacityX) x += 1000.0;
        tfs.push_back(far);
    }
    for (auto& tf : tfs) tf = testing::withFloatBreaks(tf);
    return tfs;
}

// The float (one GPU thread) and lane (CPU batch) instantiations of the Gaussian body against
// the double body at the same float μ and σ, for σ from 0 to kMaxFloatSigmaOverPiece × the TF's
// narrowest piece (the range the kernels give the float bodies). The float closed form loses
// ~(σ/w)² × float rounding (expected_tf.h: ~6e−8·(σ/w)², 4e−6 at σ = 8w) on top of the float
// Φ and exp. Measured worst 6.9e−7 (AVX-512); bound 5e−6.
TEST(ExpectedTfGaussian, FloatAndLaneBodiesMatchTheDoubleBody) {
    using lanes::Vf;
    CounterRng rng(43, 0, 0);
    for (const TransferFunction1D& tf : floatBodyTfs(rng)) {
        const TfPiecesStorage st(tf);
        const auto [lo, hi] = tf.domain();
        const double w = std::min(st.exact().narrowestPiece, hi - lo);
        const double maxSigma = kMaxFloatSigmaOverPiece * w;
        const bool small = st.fast().stride == kTfSmall;
        for (int batch = 0; batch < 40; ++batch) {
            Vf mu, sigma;
            for (int l = 0; l < lanes::kWidth; ++l) {
                mu[l] = static_cast<float>(lo - 0.2 * (hi - lo) + 1.4 * (hi - lo) * rng.uniform());
                const double u = rng.uniform();
                sigma[l] =
                    u < 0.15 ? 0.f : static_cast<float>(maxSigma * std::pow(1e-4, rng.uniform()));
            }
            Vf out[4];
            if (small)
                expectedTfGaussian<Vf>(st.fast().sized<kTfSmall>(), mu, sigma, lanes::allTrue<Vf>(),
                                       out);
            else
                expectedTfGaussian<Vf>(st.fast(), mu, sigma, lanes::allTrue<Vf>(), out);
            for (int l = 0; l < lanes::kWidth; ++l) {
                double want[4];
                expectedTfGaussian<double>(st.exact(), mu[l], sigma[l], true, want);
                float f[4];
                expectedTfGaussian<float>(st.fast(), mu[l], sigma[l], true, f);
                for (int ch = 0; ch < 4; ++ch) {
                    EXPECT_NEAR(out[ch][l], want[ch], 5e-6) << mu[l] << " " << sigma[l];
                    EXPECT_NEAR(f[ch], want[ch], 5e-6) << mu[l] << " " << sigma[l];
                }
            }
        }
    }
}

// Lanes outside the live mask do not change the live lanes' results (bit for bit, whatever they
// hold: NaN, ±inf, σ far wider than the TF).
TEST(ExpectedTfGaussian, LaneBodyRespectsTheLiveMask) {
    using lanes::Vf;
    CounterRng rng(44, 0, 0);
    const float garbageMu[4] = {std::nanf(""), INFINITY, -1e30f, 1e30f};
    const float garbageSigma[4] = {1e30f, std::nanf(""), INFINITY, 1e6f};
    for (const TransferFunction1D& tf : floatBodyTfs(rng)) {
        const TfPiecesStorage st(tf);
        const auto [lo, hi] = tf.domain();
        const double maxSigma =
            kMaxFloatSigmaOverPiece * std::min(st.exact().narrowestPiece, hi - lo);
        for (int batch = 0; batch < 20; ++batch) {
            Vf mu, sigma, muDead, sigmaDead;
            for (int l = 0; l < lanes::kWidth; ++l) {
                mu[l] = static_cast<float>(lo + (hi - lo) * rng.uniform());
                sigma[l] = static_cast<float>(maxSigma * rng.uniform());
                muDead[l] = garbageMu[(l + batch) % 4];
                sigmaDead[l] = garbageSigma[(l + 2 * batch) % 4];
            }
            const lanes::Mask live = lanes::fromBits(
                static_cast<std::uint32_t>(rng.nextBits() & ((1u << lanes::kWidth) - 1u)));
            Vf all[4], masked[4];
            expectedTfGaussian<Vf>(st.fast(), mu, sigma, lanes::allTrue<Vf>(), all);
            expectedTfGaussian<Vf>(st.fast(), lanes::select(live, mu, muDead),
                                   lanes::select(live, sigma, sigmaDead), live, masked);
            for (int l = 0; l < lanes::kWidth; ++l) {
                if (!live[l]) continue;
                for (int ch = 0; ch < 4; ++ch) EXPECT_EQ(masked[ch][l], all[ch][l]) << l;
            }
        }
    }
}

}  // namespace
}  // namespace udvr
