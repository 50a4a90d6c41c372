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
    for (const char* bad : {"", "silverman2", "-1", "0", "nan", "inf", "1e999", "0.5x"})
        EXPECT_THROW(parseBandwidth(bad), UdvrError) << bad;
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
