#include "udvr/data/synthetic.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "udvr/data/noise.h"

namespace udvr {

TEST(Synthetic, TangleMatchesClosedFormAndRange) {
    ScalarField f = makeTangle(65, 65, 65);
    // The grid includes the box corners and centre: f(0,0,0) = 11.8, f(±2.5,…) =
    // 3·(39.0625−31.25)+11.8.
    EXPECT_NEAR(f.values[f.grid.index(32, 32, 32)], 11.8, 1e-5);
    EXPECT_NEAR(f.values[f.grid.index(0, 0, 0)], 3 * (39.0625 - 31.25) + 11.8, 1e-4);
    EXPECT_DOUBLE_EQ(f.grid.spacing[0], 5.0 / 64.0);
    auto [lo, hi] = std::minmax_element(f.values.begin(), f.values.end());
    EXPECT_GT(*lo, -6.95f - 1e-4f);
    EXPECT_NEAR(*hi, 35.2375, 1e-4);
}

TEST(Synthetic, NestedSpheresHaveFourShellValuesAndZero) {
    ScalarField f = makeNestedSpheres(101, 101, 101);
    std::vector<float> distinct(f.values.begin(), f.values.end());
    std::sort(distinct.begin(), distinct.end());
    distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
    ASSERT_EQ(distinct.size(), 5u);
    EXPECT_EQ(distinct[0], 0.f);
    EXPECT_EQ(distinct[4], 100.f);
    // Point at radius 0.4 along x: index 50 + 0.4/0.02 = 70.
    EXPECT_EQ(f.values[f.grid.index(70, 50, 50)], 50.f);
}

TEST(Synthetic, UnknownNameIsAUserError) {
    EXPECT_THROW(makeSyntheticField("torus", 8, 8, 8), UdvrError);
    EXPECT_THROW(makeTangle(1, 8, 8), UdvrError);
}

TEST(Noise, BimodalMatchesItsMixtureMoments) {
    ScalarField f;
    f.grid.dims = {40, 40, 40};
    f.values.assign(f.grid.pointCount(), 0.f);
    f.values[0] = 10.f;  // range R = 10
    NoiseParams p;       // defaults: 80 % N(0, (0.2)^2), 20 % N(2, (0.4)^2) in units of R=10
    Ensemble e = perturbField(f, 4, p);
    // Pool members over voxels 1.. (truth 0). Mixture mean = 0.2·2 = 0.4;
    // variance = 0.8·0.04 + 0.2·(0.16 + 4) − 0.16 = 0.704.
    double s = 0, s2 = 0, outliers = 0;
    std::size_t n = 0;
    for (int m = 0; m < e.members; ++m)
        for (std::size_t v = 1; v < f.grid.pointCount(); ++v) {
            double x = e.member(m)[v];
            s += x;
            s2 += x * x;
            outliers += x > 1.0;
            ++n;
        }
    const double mean = s / static_cast<double>(n), var = s2 / static_cast<double>(n) - mean * mean;
    // n ≈ 256000: standard error of the mean ≈ sqrt(0.704/n) ≈ 0.0017; 5 s.e. tolerance.
    EXPECT_NEAR(mean, 0.4, 0.0085);
    EXPECT_NEAR(var, 0.704, 0.01);
    EXPECT_NEAR(outliers / static_cast<double>(n), 0.2, 0.004);
}

TEST(Noise, SameSeedSameEnsembleDifferentSeedDifferent) {
    ScalarField f = makeTangle(8, 8, 8);
    NoiseParams p;
    p.seed = 7;
    Ensemble a = perturbField(f, 3, p), b = perturbField(f, 3, p);
    EXPECT_EQ(a.values, b.values);
    p.seed = 8;
    Ensemble c = perturbField(f, 3, p);
    EXPECT_NE(a.values, c.values);
    EXPECT_THROW(perturbField(f, 1, p), UdvrError);
}

}  // namespace udvr
