#include "udvr/stats/voxel_stats.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "udvr/stats/reference_stats_test_util.h"
#include "udvr/util/check.h"
#include "udvr/util/random.h"

namespace udvr {
namespace {

using testref::bisectKdeQuantile;
using testref::exactKdeCdf;
using testref::numpyQuantile;

// A bimodal sample like `perturb`'s: 80 % around `centre`, 20 % outliers above.
std::vector<float> bimodalSample(int n, std::uint64_t seed, double centre = 10.0) {
    CounterRng rng(seed, 7, 0);
    std::vector<float> v(static_cast<std::size_t>(n));
    for (float& x : v)
        x = static_cast<float>(rng.uniform() < 0.8 ? centre + 0.5 * rng.normal()
                                                   : centre + 3.0 + 1.0 * rng.normal());
    std::sort(v.begin(), v.end());
    return v;
}

}  // namespace

TEST(VoxelStats, MomentsMatchLongDoubleSums) {
    for (int n : {2, 3, 20, 50, 1000}) {
        std::vector<float> s = bimodalSample(n, static_cast<std::uint64_t>(n), 1000.0);
        long double sum = 0.0L;
        for (float v : s) sum += v;
        const long double mean = sum / n;
        long double ss = 0.0L;
        for (float v : s) ss += (v - mean) * (v - mean);
        const long double sd = std::sqrt(ss / (n - 1));
        const SampleMoments m = sampleMoments(s);
        EXPECT_NEAR(static_cast<float>(m.mean), static_cast<float>(mean), 1e-7 * 1000.0) << n;
        EXPECT_NEAR(m.stddev, static_cast<double>(sd), 1e-6 * static_cast<double>(sd)) << n;
        EXPECT_EQ(m.min, *std::min_element(s.begin(), s.end()));
        EXPECT_EQ(m.max, *std::max_element(s.begin(), s.end()));
    }
    const std::vector<float> c(10, 3.25f);
    EXPECT_EQ(sampleMoments(c).stddev, 0.0);
    EXPECT_EQ(sampleMoments(c).mean, 3.25);
}

TEST(VoxelStats, EmpiricalQuantilesMatchNumpyFormula) {
    for (int n : {2, 5, 20, 50, 333}) {
        const std::vector<float> s = bimodalSample(n, 100 + static_cast<std::uint64_t>(n));
        std::vector<float> shuffled(s.rbegin(), s.rend());
        for (int q : {1, 4, 8, 16}) {
            for (int j = 0; j <= q; ++j) {
                const double p = static_cast<double>(j) / q;
                const auto ref = static_cast<double>(numpyQuantile(shuffled, p));
                EXPECT_NEAR(empiricalQuantile(s, p), ref, 1e-12 * 20.0)
                    << n << " " << j << "/" << q;
            }
        }
        EXPECT_EQ(empiricalQuantile(s, 0.0), s.front());
        EXPECT_EQ(empiricalQuantile(s, 1.0), s.back());
    }
}

TEST(VoxelStats, BandwidthRulesFollowSpec) {
    const std::vector<float> s = bimodalSample(50, 3);
    const double sd = sampleMoments(s).stddev;
    const double iqr = empiricalQuantile(s, 0.75) - empiricalQuantile(s, 0.25);
    const double nf = std::pow(50.0, -0.2);
    EXPECT_NEAR(kdeBandwidth(s, sd, parseBandwidth("scott")), sd * nf, 1e-12);
    EXPECT_NEAR(kdeBandwidth(s, sd, parseBandwidth("silverman")),
                0.9 * std::min(sd, iqr / 1.34) * nf, 1e-12);
    EXPECT_EQ(kdeBandwidth(s, sd, parseBandwidth("0.25")), 0.25);
    // IQR = 0 (one outlier among equal values): σ alone.
    const std::vector<float> spike{1, 1, 1, 1, 1, 1, 1, 5};
    const double sdSpike = sampleMoments(spike).stddev;
    EXPECT_NEAR(kdeBandwidth(spike, sdSpike, parseBandwidth("silverman")),
                0.9 * sdSpike * std::pow(8.0, -0.2), 1e-12);
}

TEST(VoxelStats, BadDensityAndBandwidthAreUserErrors) {
    EXPECT_THROW(parseDensityEstimate("histogram"), UdvrError);
    EXPECT_EQ(parseDensityEstimate("kde"), DensityEstimate::Kde);
    EXPECT_EQ(parseDensityEstimate("dequantized"), DensityEstimate::Dequantized);
    for (const char* bad : {"", "silverman2", "-1", "0", "nan", "inf", "1e999", "0.5x"})
        EXPECT_THROW(parseBandwidth(bad), UdvrError) << bad;
}

namespace {
// F of the dequantised sample, summed directly: (1/n)·Σ clamp((x − x_i)/s + ½, 0, 1).
double dequantizedCdf(const std::vector<float>& s, double step, double x) {
    long double sum = 0.0L;
    for (float v : s) sum += std::clamp((x - v) / step + 0.5, 0.0, 1.0);
    return static_cast<double>(sum / static_cast<long double>(s.size()));
}
std::vector<double> dequantized(const std::vector<float>& s, double step,
                                const std::vector<double>& levels) {
    std::vector<double> out(levels.size());
    dequantizedQuantiles(s, step, levels, out);
    return out;
}
}  // namespace

TEST(VoxelStats, DequantizedQuantilesByHand) {
    // {0, 0, 0, 1}, s = 1: mass 3/4 on [−½, ½], 1/4 on [½, 1½].
    const std::vector<double> tie = dequantized({0, 0, 0, 1}, 1.0, {0, 0.375, 0.5, 0.75, 0.9, 1});
    const double tieRef[] = {-0.5, 0.0, 1.0 / 6.0, 0.5, 1.1, 1.5};
    for (std::size_t k = 0; k < tie.size(); ++k) EXPECT_NEAR(tie[k], tieRef[k], 1e-15) << k;
    // A gap: F is flat at ½ on [½, 4½]; F⁻¹(½) is its left end, a hair above jumps across.
    const std::vector<double> gap = dequantized({0, 0, 5, 5}, 1.0, {0.25, 0.5, 0.5 + 1e-9, 0.75});
    EXPECT_EQ(gap[0], 0.0);
    EXPECT_EQ(gap[1], 0.5);
    EXPECT_NEAR(gap[2], 4.5, 1e-8);
    EXPECT_EQ(gap[3], 5.0);
    // A constant voxel is the uniform over its step, not a point mass.
    EXPECT_EQ(dequantized({3, 3, 3}, 2.0, {0.0, 0.25, 0.5, 1.0}),
              (std::vector<double>{2.0, 2.5, 3.0, 4.0}));
    // Overlapping steps (centres 0.3 apart, s = 1): slopes ½, 1, ½ on [−½, −0.2, ½, 0.8].
    const std::vector<double> ov = dequantized({0.0f, 0.3f}, 1.0, {0.15, 0.5, 0.9});
    EXPECT_NEAR(ov[0], -0.2, 1e-7);
    EXPECT_NEAR(ov[1], 0.15, 1e-7);
    EXPECT_NEAR(ov[2], 0.6, 1e-7);
}

// Random integer samples with ties (step 1, ½, 4): every F⁻¹(p) has F = p by a direct sum, and
// is the smallest such x (F(x − δ) < p), within the double rounding of the walk.
TEST(VoxelStats, DequantizedQuantilesInvertTheDirectCdf) {
    for (double step : {1.0, 0.5, 4.0})
        for (int n : {2, 8, 64, 125}) {
            CounterRng rng(31, static_cast<std::uint64_t>(n), static_cast<std::uint64_t>(step));
            std::vector<float> s;
            for (int i = 0; i < n; ++i)  // few distinct values: many ties, some gaps
                s.push_back(static_cast<float>(step * std::floor(rng.uniform() * 6.0) *
                                               (rng.uniform() < 0.3 ? 3.0 : 1.0)));
            std::sort(s.begin(), s.end());
            std::vector<double> levels;
            for (int j = 0; j <= 16; ++j) levels.push_back(j / 16.0);
            levels.push_back(0.3);
            levels.push_back(1.0 / 3.0);
            std::sort(levels.begin(), levels.end());
            const std::vector<double> x = dequantized(s, step, levels);
            for (std::size_t k = 0; k < levels.size(); ++k) {
                const double p = levels[k];
                SCOPED_TRACE("step " + std::to_string(step) + " n " + std::to_string(n) + " p " +
                             std::to_string(p));
                if (k > 0) {
                    EXPECT_GE(x[k], x[k - 1]);
                }
                EXPECT_GE(x[k], s.front() - 0.5 * step);
                EXPECT_LE(x[k], s.back() + 0.5 * step);
                if (p > 0.0 && p < 1.0) {
                    EXPECT_NEAR(dequantizedCdf(s, step, x[k]), p, 1e-12);
                    EXPECT_LT(dequantizedCdf(s, step, x[k] - 1e-9 * step), p);
                }
            }
        }
}

TEST(VoxelStats, KdeQuantilesMatchBisectionOnExactCdf) {
    for (int n : {5, 20, 50, 400}) {
        const std::vector<float> s = bimodalSample(n, 200 + static_cast<std::uint64_t>(n));
        const double range = s.back() - s.front();
        for (const char* rule : {"silverman", "scott", "0.05"}) {
            const double h = kdeBandwidth(s, sampleMoments(s).stddev, parseBandwidth(rule));
            for (double p : {0.5 / n, 0.01, 0.125, 0.25, 0.5, 0.75, 0.875, 0.99, 1.0 - 0.5 / n}) {
                const double x = kdeQuantile(s, h, p, empiricalQuantile(s, p));
                const auto ref = static_cast<double>(bisectKdeQuantile(s, h, p));
                EXPECT_NEAR(x, ref, 1e-7 * range) << n << " " << rule << " p=" << p;
                EXPECT_NEAR(static_cast<double>(exactKdeCdf(s, h, x)), p, 1e-9);
            }
            // A poor guess still converges (bracketing fallback).
            EXPECT_NEAR(kdeQuantile(s, h, 0.3, s.back() + 1e3 * range),
                        static_cast<double>(bisectKdeQuantile(s, h, 0.3)), 1e-7 * range);
        }
    }
}

// Cross-check with numpy/scipy where they exist: numpy.quantile and the quantiles of
// scipy.stats.gaussian_kde(bw_method='scott') (h = σ·n^(−1/5)), inverted with brentq.
TEST(VoxelStats, AgreesWithNumpyAndScipy) {
    if (std::system("/usr/bin/python3 -c 'import numpy, scipy.stats, scipy.optimize' "
                    ">/dev/null 2>&1") != 0)
        GTEST_SKIP() << "python3 with numpy/scipy not available";
    const auto dir =
        std::filesystem::temp_directory_path() / ("udvr_stats_scipy_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const std::vector<float> s = bimodalSample(50, 42);
    {
        std::ofstream f(dir / "s.txt");
        f.precision(9);
        for (float v : s) f << v << "\n";
    }
    const std::string script =
        "import numpy as np, scipy.stats as st, scipy.optimize as so\n"
        "x = np.loadtxt('" +
        (dir / "s.txt").string() +
        "', dtype=np.float32).astype(float)\n"
        "k = st.gaussian_kde(x, bw_method='scott')\n"
        "F = lambda t: k.integrate_box_1d(-np.inf, t)\n"
        "ps = [0.01, 0.125, 0.25, 0.5, 0.75, 0.875, 0.99]\n"
        "out = [np.quantile(x, p) for p in ps]\n"
        "out += [so.brentq(lambda t: F(t) - p, x.min() - 10, x.max() + 10, xtol=1e-12) "
        "for p in ps]\n"
        "np.savetxt('" +
        (dir / "out.txt").string() + "', out, fmt='%.12g')\n";
    {
        std::ofstream f(dir / "ref.py");
        f << script;
    }
    ASSERT_EQ(std::system(("/usr/bin/python3 " + (dir / "ref.py").string()).c_str()), 0);
    std::ifstream in(dir / "out.txt");
    std::vector<double> ref;
    for (double v; in >> v;) ref.push_back(v);
    ASSERT_EQ(ref.size(), 14u);
    const double ps[] = {0.01, 0.125, 0.25, 0.5, 0.75, 0.875, 0.99};
    const double h = kdeBandwidth(s, sampleMoments(s).stddev, parseBandwidth("scott"));
    const double range = s.back() - s.front();
    for (int i = 0; i < 7; ++i) {
        EXPECT_NEAR(empiricalQuantile(s, ps[i]), ref[static_cast<std::size_t>(i)], 1e-6 * range);
        EXPECT_NEAR(kdeQuantile(s, h, ps[i], empiricalQuantile(s, ps[i])),
                    ref[static_cast<std::size_t>(7 + i)], 1e-5 * range);
    }
    std::filesystem::remove_all(dir);
}

}  // namespace udvr
