#include "udvr/stats/value_summary.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "udvr/util/check.h"

namespace udvr {
namespace {

// numpy.percentile(x, p) (method "linear") from a fully sorted copy: the definition itself.
double sortedPercentile(std::vector<float> x, double p) {
    std::sort(x.begin(), x.end());
    const double rank = (static_cast<double>(x.size()) - 1.0) * p / 100.0;
    const auto k = static_cast<std::size_t>(std::floor(rank));
    const double f = rank - static_cast<double>(k);
    const double hi = k + 1 < x.size() ? x[k + 1] : x[k];
    return x[k] + f * (hi - x[k]);
}

TEST(ValueSummary, PercentilesMatchTheSortedDefinitionInAnyRequestOrder) {
    std::mt19937 rng(7);
    std::lognormal_distribution<float> dist(0.0f, 1.5f);
    for (std::size_t n : {1u, 2u, 3u, 10u, 1001u, 20000u}) {
        std::vector<float> x(n);
        for (float& v : x) v = dist(rng);
        x[n / 2] = x[0];  // ties
        const std::vector<double> p{50, 0, 99.5, 0.5, 100, 25, 25, 75, 1, 99, 5, 95, 37.3};
        const std::vector<double> got = percentiles(x, p);
        for (std::size_t i = 0; i < p.size(); ++i)
            EXPECT_DOUBLE_EQ(got[i], sortedPercentile(x, p[i])) << "n " << n << " p " << p[i];
    }
}

TEST(ValueSummary, MomentsAndPercentilesOfAKnownSet) {
    std::vector<float> x;
    for (int i = 0; i <= 100; ++i) x.push_back(static_cast<float>(100 - i));  // 0..100 reversed
    const ValueSummary s = summarizeValues(x);
    EXPECT_EQ(s.count, 101u);
    EXPECT_EQ(s.min, 0.0);
    EXPECT_EQ(s.max, 100.0);
    EXPECT_DOUBLE_EQ(s.mean, 50.0);
    // Population variance of 0..100: (101² − 1) / 12 = 850.
    EXPECT_NEAR(s.stddev, std::sqrt(850.0), 1e-12);
    // Rank (n−1)·p/100 = p on 0..100: each percentile is its own value.
    for (double p : kSummaryPercentiles) EXPECT_NEAR(s.percentile(p), p, 1e-12) << p;
    EXPECT_THROW(s.percentile(42.0), UdvrError);
    const auto r = robustRange(s);
    EXPECT_DOUBLE_EQ(r[0], 0.5);
    EXPECT_DOUBLE_EQ(r[1], 99.5);
}

TEST(ValueSummary, RobustRangeWidensForMostlyConstantAndConstantVolumes) {
    std::vector<float> mostly(1000, 3.0f);
    mostly[10] = 7.0f;  // one outlier: p0.5 = p99.5 = 3
    auto r = robustRange(summarizeValues(mostly));
    EXPECT_EQ(r[0], 3.0);
    EXPECT_EQ(r[1], 7.0);
    std::vector<float> constant(10, -2.0f);
    r = robustRange(summarizeValues(constant));
    EXPECT_EQ(r[0], -2.5);
    EXPECT_EQ(r[1], -1.5);
}

TEST(ValueSummary, HistogramCountsEveryValueOnce) {
    const std::vector<float> x{-1.0f, 0.0f, 0.24f, 0.25f, 0.5f, 0.99f, 1.0f, 2.0f};
    const Histogram h = histogramOf(x, 0.0, 1.0, 4);
    ASSERT_EQ(h.counts.size(), 4u);
    EXPECT_EQ(h.counts[0], 2u);  // 0, 0.24
    EXPECT_EQ(h.counts[1], 1u);  // 0.25
    EXPECT_EQ(h.counts[2], 1u);  // 0.5
    EXPECT_EQ(h.counts[3], 2u);  // 0.99 and the upper end 1.0
    EXPECT_EQ(h.below, 1u);
    EXPECT_EQ(h.above, 1u);
    EXPECT_THROW(histogramOf(x, 1.0, 1.0, 4), UdvrError);
    EXPECT_THROW(histogramOf(x, 0.0, 1.0, 0), UdvrError);
}

}  // namespace
}  // namespace udvr

namespace udvr {
namespace {

// A constant volume far from 0: ±0.5 rounds away at 1e17 (an empty range reached the preset's
// internal check, issue 34); the margin grows with the value.
TEST(ValueSummary, RobustRangeOfALargeConstantIsNotEmpty) {
    for (float v : {0.f, 1.f, -3.f, 1e17f, -1e17f, 3e38f}) {
        const std::vector<float> x(100, v);
        const auto r = robustRange(summarizeValues(x));
        EXPECT_LT(r[0], r[1]) << v;
        EXPECT_LE(r[0], v);
        EXPECT_GE(r[1], v);
        EXPECT_TRUE(std::isfinite(r[0]) && std::isfinite(r[1])) << v;
    }
}

}  // namespace
}  // namespace udvr
