#include "udvr/stats/gmm.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "udvr/util/random.h"

namespace udvr {
namespace {

struct Truth {
    double pi, mu, sigma;
};

std::vector<float> mixtureSample(const std::vector<Truth>& t, int n, std::uint64_t seed) {
    CounterRng rng(seed, 3, 0);
    std::vector<float> v;
    for (int i = 0; i < n; ++i) {
        double u = rng.uniform();
        std::size_t k = 0;
        while (k + 1 < t.size() && u >= t[k].pi) u -= t[k++].pi;
        v.push_back(static_cast<float>(t[k].mu + t[k].sigma * rng.normal()));
    }
    std::sort(v.begin(), v.end());
    return v;
}

}  // namespace

TEST(Gmm, RecoversAWellSeparatedThreeComponentMixture) {
    const std::vector<Truth> truth{{0.5, -2.0, 0.5}, {0.3, 1.0, 0.7}, {0.2, 4.0, 0.4}};
    const int n = 6000;
    const std::vector<float> s = mixtureSample(truth, n, 11);
    GmmOptions opt;
    opt.components = 3;
    opt.sigmaFloor = 1e-3 * (s.back() - s.front());
    std::vector<float> out(9);
    GmmWorkspace ws;
    const GmmFitInfo info = fitGmm(s, opt, 0, out, ws);
    EXPECT_TRUE(info.converged);
    EXPECT_EQ(info.distinctComponents, 3);
    for (int k = 0; k < 3; ++k) {
        const Truth& t = truth[static_cast<std::size_t>(k)];
        // Tolerances: 5 standard errors of the estimate from n·π samples.
        const double nk = n * t.pi;
        EXPECT_NEAR(out[k], t.pi, 5.0 * std::sqrt(t.pi * (1 - t.pi) / n)) << k;
        EXPECT_NEAR(out[3 + k], t.mu, 5.0 * t.sigma / std::sqrt(nk)) << k;
        EXPECT_NEAR(out[6 + k], t.sigma, 5.0 * t.sigma / std::sqrt(2.0 * nk)) << k;
    }
    // The reported log-likelihood (vectorised exp/log inside) against a direct evaluation.
    double ll = 0.0;
    for (float v : s) {
        double p = 0.0;
        for (int k = 0; k < 3; ++k) {
            const double z = (v - out[3 + k]) / out[6 + k];
            p += out[k] * std::exp(-0.5 * z * z) / (out[6 + k] * std::sqrt(2.0 * M_PI));
        }
        ll += std::log(p);
    }
    EXPECT_NEAR(info.meanLogLikelihood, ll / n, 1e-5);
}

TEST(Gmm, OutputIsSortedNormalisedFlooredAndDeterministic) {
    const std::vector<float> s = mixtureSample({{0.8, 0.0, 1.0}, {0.2, 3.0, 1.0}}, 50, 5);
    GmmOptions opt;
    opt.components = 4;
    opt.sigmaFloor = 0.05;
    std::vector<float> a(12), b(12);
    GmmWorkspace ws;
    const GmmFitInfo info = fitGmm(s, opt, 17, a, ws);
    fitGmm(s, opt, 17, b, ws);
    EXPECT_EQ(a, b);
    EXPECT_LE(info.iterations, 100);
    double sum = 0.0;
    for (int k = 0; k < 4; ++k) {
        sum += a[k];
        EXPECT_GE(a[8 + k], 0.05f);
        if (k > 0) {
            EXPECT_LE(a[4 + k - 1], a[4 + k]);
        }
    }
    EXPECT_NEAR(sum, 1.0, 1e-6);
    // The fit's mean equals the sample mean (an EM fixed-point property of the M-step).
    double mixMean = 0.0, sampleMean = 0.0;
    for (int k = 0; k < 4; ++k) mixMean += a[k] * a[4 + k];
    for (float v : s) sampleMean += v;
    EXPECT_NEAR(mixMean, sampleMean / 50.0, 1e-4);
}

TEST(Gmm, ConstantVoxelIsAPointMass) {
    const std::vector<float> s(20, 2.5f);
    GmmOptions opt;
    opt.components = 4;
    opt.sigmaFloor = 0.01;
    std::vector<float> out(12);
    GmmWorkspace ws;
    const GmmFitInfo info = fitGmm(s, opt, 0, out, ws);
    EXPECT_EQ(info.distinctComponents, 1);
    EXPECT_FLOAT_EQ(out[0] + out[1] + out[2] + out[3], 1.0f);
    EXPECT_EQ(*std::max_element(out.begin(), out.begin() + 4), 1.0f);
    for (int k = 0; k < 4; ++k) {
        EXPECT_EQ(out[4 + k], 2.5f);
        EXPECT_FLOAT_EQ(out[8 + k], 0.01f);
    }
}

TEST(Gmm, FewerDistinctValuesThanComponents) {
    // Two values, 3:1: two components at the values, weights 0.75/0.25; the rest weight 0.
    std::vector<float> s(40, 1.0f);
    std::fill(s.begin() + 30, s.end(), 3.0f);
    GmmOptions opt;
    opt.components = 4;
    opt.sigmaFloor = 0.002;
    std::vector<float> out(12);
    GmmWorkspace ws;
    const GmmFitInfo info = fitGmm(s, opt, 0, out, ws);
    EXPECT_EQ(info.distinctComponents, 2);
    std::vector<std::pair<float, float>> live;  // (μ, π) of live components
    for (int k = 0; k < 4; ++k)
        if (out[k] > 0) live.push_back({out[4 + k], out[k]});
    ASSERT_EQ(live.size(), 2u);
    EXPECT_NEAR(live[0].first, 1.0, 1e-6);
    EXPECT_NEAR(live[0].second, 0.75, 1e-6);
    EXPECT_NEAR(live[1].first, 3.0, 1e-6);
    EXPECT_NEAR(live[1].second, 0.25, 1e-6);
}

}  // namespace udvr
