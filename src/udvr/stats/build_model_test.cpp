#include "udvr/stats/build_model.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "udvr/stats/reference_stats_test_util.h"
#include "udvr/util/check.h"
#include "udvr/util/parallel.h"
#include "udvr/util/random.h"

namespace udvr {
namespace {

using testref::bisectKdeQuantile;
using testref::exactKdeCdf;
using testref::numpyQuantile;

// n members on an X×Y×Z grid; voxel value ~ truth(v) + bimodal noise, a few constant voxels.
Ensemble makeEnsemble(std::array<int, 3> dims, int n, std::uint64_t seed) {
    Ensemble e;
    e.grid.dims = dims;
    e.grid.origin = {1.0, -2.0, 0.5};
    e.grid.spacing = {0.5, 0.25, 2.0};
    e.members = n;
    const std::size_t P = e.grid.pointCount();
    e.values.resize(P * static_cast<std::size_t>(n));
    for (int m = 0; m < n; ++m)
        for (std::size_t v = 0; v < P; ++v) {
            CounterRng rng(seed, v, static_cast<std::uint64_t>(m));
            const double truth = 0.1 * static_cast<double>(v);
            double x =
                truth + (rng.uniform() < 0.8 ? 0.3 * rng.normal() : 1.5 + 0.5 * rng.normal());
            if (v % 7 == 3) x = truth;  // constant voxel
            e.member(m)[v] = static_cast<float>(x);
        }
    return e;
}

std::vector<float> samplesOf(const Ensemble& e, std::size_t v) {
    std::vector<float> s;
    for (int m = 0; m < e.members; ++m) s.push_back(e.member(m)[v]);
    return s;
}

}  // namespace

TEST(BuildModel, EnsembleMomentsAndEmpiricalQuantiles) {
    const Ensemble e = makeEnsemble({6, 5, 4}, 20, 1);
    BuildOptions opt;
    opt.source = "test";
    BuildReport rep;
    const ModelVolume m = buildModel(e, opt, &rep);
    const std::size_t P = e.grid.pointCount();
    ASSERT_EQ(m.mean.size(), P);
    ASSERT_EQ(m.quantiles.size(), P * 9);
    ASSERT_EQ(m.iqr.size(), P * 2);
    ASSERT_EQ(m.gmm.size(), P * 12);
    EXPECT_EQ(m.quantileCount, 8);
    EXPECT_EQ(m.gmmComponents, 4);
    EXPECT_EQ(m.density, "empirical");
    EXPECT_EQ(m.bandwidth, 0.0);
    EXPECT_EQ(m.bandwidthRule, "");
    EXPECT_EQ(m.tailEps, 0.0);
    EXPECT_EQ(m.samplesPerVoxel, 20);
    EXPECT_EQ(m.downsample, 0);
    EXPECT_EQ(m.source, "test");
    EXPECT_EQ(m.bounds, e.grid.bounds());
    EXPECT_EQ(m.fullResMinSpacing, 0.25);
    EXPECT_EQ(rep.constantVoxels, (P + 3) / 7);
    for (std::size_t v = 0; v < P; ++v) {
        const std::vector<float> s = samplesOf(e, v);
        long double sum = 0.0L;
        for (float x : s) sum += x;
        const long double mean = sum / 20;
        long double ss = 0.0L;
        for (float x : s) ss += (x - mean) * (x - mean);
        const double scale = std::max(1.0, std::fabs(static_cast<double>(mean)));
        EXPECT_NEAR(m.mean[v], static_cast<double>(mean), 2e-7 * scale);
        EXPECT_NEAR(m.stddev[v], static_cast<double>(std::sqrt(ss / 19)), 2e-7 * scale);
        EXPECT_EQ(m.min[v], *std::min_element(s.begin(), s.end()));
        EXPECT_EQ(m.max[v], *std::max_element(s.begin(), s.end()));
        for (int j = 0; j <= 8; ++j)
            EXPECT_NEAR(m.quantilesAt(v)[j], static_cast<double>(numpyQuantile(s, j / 8.0L)),
                        2e-7 * scale);
        EXPECT_NEAR(m.iqr[2 * v], static_cast<double>(numpyQuantile(s, 0.25L)), 2e-7 * scale);
        EXPECT_NEAR(m.iqr[2 * v + 1], static_cast<double>(numpyQuantile(s, 0.75L)), 2e-7 * scale);
        float piSum = 0.f;
        for (int k = 0; k < 4; ++k) piSum += m.gmmAt(v)[k];
        EXPECT_NEAR(piSum, 1.0f, 1e-5f);
    }
}

TEST(BuildModel, ConstantVoxelsArePointMasses) {
    const Ensemble e = makeEnsemble({4, 3, 2}, 10, 2);
    for (auto density : {DensityEstimate::Empirical, DensityEstimate::Kde}) {
        BuildOptions opt;
        opt.density = density;
        const ModelVolume m = buildModel(e, opt);
        const std::size_t v = 3;  // constant by construction
        const float value = e.member(0)[v];
        for (int j = 0; j <= 8; ++j) EXPECT_EQ(m.quantilesAt(v)[j], value);
        EXPECT_EQ(m.iqr[2 * v], value);
        EXPECT_EQ(m.iqr[2 * v + 1], value);
        EXPECT_EQ(m.stddev[v], 0.f);
        for (int k = 0; k < 4; ++k) EXPECT_EQ(m.gmmAt(v)[4 + k], value);
    }
}

TEST(BuildModel, KdeQuantilesMatchBisection) {
    const Ensemble e = makeEnsemble({5, 4, 3}, 30, 3);
    for (const char* rule : {"silverman", "scott", "0.2"}) {
        BuildOptions opt;
        opt.density = DensityEstimate::Kde;
        opt.bandwidth = parseBandwidth(rule);
        opt.bandwidthText = rule;
        opt.gmmComponents = 0;
        const ModelVolume m = buildModel(e, opt);
        EXPECT_EQ(m.density, "kde");
        EXPECT_EQ(m.bandwidthRule, rule);
        EXPECT_DOUBLE_EQ(m.tailEps, 1.0 / 60.0);
        EXPECT_TRUE(m.gmm.empty());
        std::vector<double> hs;
        for (std::size_t v = 0; v < e.grid.pointCount(); v += 5) {
            const std::vector<float> s = samplesOf(e, v);
            auto [mn, mx] = std::minmax_element(s.begin(), s.end());
            if (*mn == *mx) continue;
            const double range = *mx - *mn;
            // h by the SPEC formula, computed here from the reference quantiles.
            long double sum = 0.0L;
            for (float x : s) sum += x;
            long double ss = 0.0L;
            for (float x : s) ss += (x - sum / 30) * (x - sum / 30);
            const double sd = static_cast<double>(std::sqrt(ss / 29));
            const double iqr =
                static_cast<double>(numpyQuantile(s, 0.75L) - numpyQuantile(s, 0.25L));
            double h = 0.2;
            if (std::string(rule) == "scott") h = sd * std::pow(30.0, -0.2);
            if (std::string(rule) == "silverman")
                h = 0.9 * std::min(sd, iqr / 1.34) * std::pow(30.0, -0.2);
            for (int j = 0; j <= 8; ++j) {
                const long double p = j == 0 ? 1.0L / 60 : j == 8 ? 1.0L - 1.0L / 60 : j / 8.0L;
                EXPECT_NEAR(m.quantilesAt(v)[j], static_cast<double>(bisectKdeQuantile(s, h, p)),
                            1e-5 * range)
                    << rule << " v=" << v << " j=" << j;
            }
            EXPECT_NEAR(m.iqr[2 * v], static_cast<double>(bisectKdeQuantile(s, h, 0.25L)),
                        1e-5 * range);
            EXPECT_NEAR(m.iqr[2 * v + 1], static_cast<double>(bisectKdeQuantile(s, h, 0.75L)),
                        1e-5 * range);
        }
        if (std::string(rule) == "0.2") {
            EXPECT_EQ(m.bandwidth, 0.2);
        }
        EXPECT_GT(m.bandwidth, 0.0);
    }
}

TEST(BuildModel, SkipsQuantilesAndGmmOnRequestAndIsThreadInvariant) {
    const Ensemble e = makeEnsemble({9, 8, 7}, 12, 4);
    BuildOptions opt;
    opt.quantiles = 0;
    opt.gmmComponents = 0;
    const ModelVolume skip = buildModel(e, opt);
    EXPECT_FALSE(skip.hasQuantiles());
    EXPECT_FALSE(skip.hasGmm());
    EXPECT_EQ(skip.iqr.size(), 2 * e.grid.pointCount());

    BuildOptions full;
    full.density = DensityEstimate::Kde;
    const ModelVolume all = buildModel(e, full);
    setThreadCount(1);
    const ModelVolume one = buildModel(e, full);
    setThreadCount(0);
    EXPECT_EQ(all.quantiles, one.quantiles);
    EXPECT_EQ(all.gmm, one.gmm);
    EXPECT_EQ(all.bandwidth, one.bandwidth);
}

TEST(BuildModel, APieceWithTheWholeGridsStreamsAndRangeIsTheWholeBuildsSlab) {
    // ParaView's Build Model filter on one MPI rank: z-planes [3, 7) of a 9×8×7 ensemble whose
    // values grow with the voxel index (so the piece's data range is not the whole's).
    const Ensemble e = makeEnsemble({9, 8, 7}, 12, 5);
    BuildOptions opt;
    opt.gmmComponents = 3;
    const ModelVolume whole = buildModel(e, opt);
    const std::size_t plane = 9 * 8, first = 3 * plane, count = 4 * plane;
    Ensemble piece = e;
    piece.grid.dims = {9, 8, 4};
    piece.values.resize(count * 12);
    for (int m = 0; m < 12; ++m)
        std::copy_n(e.member(m) + first, count, piece.values.begin() + m * count);
    const auto slabOf = [&](const std::vector<float>& a, std::size_t perVoxel) {
        return std::vector<float>(a.begin() + first * perVoxel,
                                  a.begin() + (first + count) * perVoxel);
    };
    const ModelVolume alone = buildModel(piece, opt);  // the piece's own streams and range
    EXPECT_NE(alone.gmm, slabOf(whole.gmm, 9));
    opt.piece.firstVoxel = first;
    const auto [lo, hi] = std::minmax_element(e.values.begin(), e.values.end());
    opt.piece.wholeMin = *lo;
    opt.piece.wholeMax = *hi;
    const ModelVolume part = buildModel(piece, opt);
    EXPECT_EQ(part.gmm, slabOf(whole.gmm, 9));
    EXPECT_EQ(part.quantiles, slabOf(whole.quantiles, 9));
    EXPECT_EQ(part.mean, slabOf(whole.mean, 1));
    EXPECT_EQ(part.stddev, slabOf(whole.stddev, 1));
}

TEST(BuildModel, DownsampledGeometryAndValues) {
    ScalarField f;
    f.grid.dims = {7, 6, 5};
    f.grid.origin = {-1.0, 2.0, 0.0};
    f.grid.spacing = {0.5, 1.0, 0.25};
    f.name = "f";
    for (std::size_t p = 0; p < f.grid.pointCount(); ++p) {
        CounterRng rng(9, p, 0);
        f.values.push_back(static_cast<float>(rng.normal()));
    }
    BuildOptions opt;
    opt.gmmComponents = 3;
    BuildReport rep;
    const ModelVolume m = buildModelDownsampled(f, 2, opt, &rep);
    EXPECT_EQ(m.grid.dims, (std::array<int, 3>{3, 3, 2}));
    EXPECT_EQ(m.grid.spacing, (std::array<double, 3>{1.0, 2.0, 0.5}));
    EXPECT_DOUBLE_EQ(m.grid.origin[0], -0.75);
    EXPECT_DOUBLE_EQ(m.grid.origin[1], 2.5);
    EXPECT_DOUBLE_EQ(m.grid.origin[2], 0.125);
    EXPECT_EQ(rep.droppedPlanes, (std::array<int, 3>{1, 0, 1}));
    EXPECT_EQ(m.downsample, 2);
    EXPECT_EQ(m.samplesPerVoxel, 8);
    EXPECT_EQ(m.bounds, f.grid.bounds());
    EXPECT_EQ(m.fullResMinSpacing, 0.25);
    for (int k = 0; k < 2; ++k)
        for (int j = 0; j < 3; ++j)
            for (int i = 0; i < 3; ++i) {
                std::vector<float> s;
                long double sum = 0.0L;
                for (int c = 0; c < 2; ++c)
                    for (int b = 0; b < 2; ++b)
                        for (int a = 0; a < 2; ++a) {
                            s.push_back(f.values[f.grid.index(2 * i + a, 2 * j + b, 2 * k + c)]);
                            sum += s.back();
                        }
                const std::size_t v = m.grid.index(i, j, k);
                EXPECT_NEAR(m.mean[v], static_cast<double>(sum / 8), 1e-6);
                EXPECT_EQ(m.min[v], *std::min_element(s.begin(), s.end()));
                EXPECT_EQ(m.max[v], *std::max_element(s.begin(), s.end()));
                EXPECT_NEAR(m.quantilesAt(v)[4], static_cast<double>(numpyQuantile(s, 0.5L)), 1e-6);
                // The reduced voxel sits at the brick centre in world space.
                EXPECT_DOUBLE_EQ(m.grid.world(0, i), f.grid.world(0, 2 * i + 0.5));
            }
}

// dequantized on an integer-typed field: each brick's boundaries are the dequantised quantiles of
// its samples (constant bricks included), the IQR at .25/.75 of the same estimate, the moments
// and GMM those of the samples as for empirical; the model records the step.
TEST(BuildModel, DequantizedBricksOfAnIntegerField) {
    ScalarField f;
    f.grid.dims = {4, 4, 2};
    f.valueType = "uint8";
    f.valueStep = 1.0;
    for (std::size_t p = 0; p < f.grid.pointCount(); ++p) {
        CounterRng rng(4, p, 0);
        const bool leftBrick = p % 4 < 2;  // x < 2: the bricks i = 0, all 7
        f.values.push_back(leftBrick ? 7.f : static_cast<float>(std::floor(rng.uniform() * 3.0)));
    }
    BuildOptions opt;
    opt.density = DensityEstimate::Dequantized;
    opt.gmmComponents = 2;
    BuildOptions empirical = opt;
    empirical.density = DensityEstimate::Empirical;
    const ModelVolume m = buildModelDownsampled(f, 2, opt);
    const ModelVolume e = buildModelDownsampled(f, 2, empirical);
    EXPECT_EQ(m.density, "dequantized");
    EXPECT_EQ(m.bandwidth, 1.0);
    EXPECT_EQ(m.mean, e.mean);
    EXPECT_EQ(m.stddev, e.stddev);
    EXPECT_EQ(m.gmm, e.gmm);
    std::vector<double> levels;
    for (int j = 0; j <= 8; ++j) levels.push_back(j / 8.0);
    for (int k = 0; k < 1; ++k)
        for (int j = 0; j < 2; ++j)
            for (int i = 0; i < 2; ++i) {
                std::vector<float> s;  // the brick's samples
                for (int c = 0; c < 2; ++c)
                    for (int b = 0; b < 2; ++b)
                        for (int a = 0; a < 2; ++a)
                            s.push_back(f.values[f.grid.index(2 * i + a, 2 * j + b, 2 * k + c)]);
                std::sort(s.begin(), s.end());
                std::vector<double> ref(9), iqr(2);
                dequantizedQuantiles(s, 1.0, levels, ref);
                dequantizedQuantiles(s, 1.0, std::vector<double>{0.25, 0.75}, iqr);
                const std::size_t v = m.grid.index(i, j, k);
                for (int q = 0; q <= 8; ++q)
                    EXPECT_EQ(m.quantilesAt(v)[q], static_cast<float>(ref[std::size_t(q)]));
                EXPECT_EQ(m.iqr[2 * v], static_cast<float>(iqr[0]));
                EXPECT_EQ(m.iqr[2 * v + 1], static_cast<float>(iqr[1]));
                if (i == 0) {  // the constant bricks of 7: U[6.5, 7.5]
                    EXPECT_EQ(m.quantilesAt(v)[0], 6.5f);
                    EXPECT_EQ(m.quantilesAt(v)[4], 7.0f);
                    EXPECT_EQ(m.quantilesAt(v)[8], 7.5f);
                }
            }
}

TEST(BuildModel, BadInputIsAOneLineUserError) {
    auto expectError = [](auto&& fn, const std::string& needle) {
        try {
            fn();
            ADD_FAILURE() << "no error, expected one mentioning '" << needle << "'";
        } catch (const UdvrError& err) {
            const std::string msg = err.what();
            EXPECT_NE(msg.find(needle), std::string::npos) << msg;
            EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
        }
    };
    Ensemble e = makeEnsemble({4, 4, 4}, 6, 5);
    BuildOptions opt;
    Ensemble one = e;
    one.members = 1;
    one.values.resize(e.grid.pointCount());
    expectError([&] { buildModel(one, opt); }, "at least 2");

    Ensemble nan = e;
    nan.member(2)[e.grid.index(1, 2, 3)] = std::numeric_limits<float>::quiet_NaN();
    nan.member(4)[e.grid.index(3, 3, 3)] = std::numeric_limits<float>::quiet_NaN();
    nan.member(0)[e.grid.index(2, 3, 3)] = std::numeric_limits<float>::infinity();
    expectError([&] { buildModel(nan, opt); },
                "3 NaN/Inf samples (first at voxel (1,2,3), member 2)");

    BuildOptions bad = opt;
    bad.quantiles = -1;
    expectError([&] { buildModel(e, bad); }, "--quantiles -1");
    bad = opt;
    bad.gmmComponents = 7;
    expectError([&] { buildModel(e, bad); }, "--gmm 7 needs at least 7 samples");
    bad = opt;
    bad.density = DensityEstimate::Kde;
    bad.bandwidth = {BandwidthRule::Fixed, -1.0};
    expectError([&] { buildModel(e, bad); }, "--bandwidth");
    bad.bandwidth = {};
    bad.tailEps = 0.6;
    expectError([&] { buildModel(e, bad); }, "--tail-eps");
    bad.tailEps = 0.2;  // > 1/q = 0.125
    expectError([&] { buildModel(e, bad); }, "exceeds 1/q");
    bad = opt;
    bad.density = DensityEstimate::Dequantized;  // float samples: no quantisation step
    expectError([&] { buildModel(e, bad); }, "needs an integer-typed input");
    Ensemble ints = e;
    ints.valueType = "int16";
    ints.valueStep = 1.0;
    EXPECT_EQ(buildModel(ints, bad).density, "dequantized");

    ScalarField f;
    f.grid.dims = {4, 5, 3};
    f.values.assign(60, 1.f);
    expectError([&] { buildModelDownsampled(f, 1, opt); }, "--downsample 1");
    expectError([&] { buildModelDownsampled(f, 4, opt); }, "larger than the grid");
    BuildOptions dq = opt;
    dq.density = DensityEstimate::Dequantized;
    f.valueType = "float32";
    expectError([&] { buildModelDownsampled(f, 2, dq); }, "holds float32 values");
    // A NaN in a left-out trailing plane (z = 2) is not a sample; one inside a brick is.
    f.values[f.grid.index(1, 0, 2)] = std::numeric_limits<float>::quiet_NaN();
    EXPECT_NO_THROW(buildModelDownsampled(f, 2, opt));
    f.values[f.grid.index(1, 0, 1)] = std::numeric_limits<float>::quiet_NaN();
    expectError([&] { buildModelDownsampled(f, 2, opt); },
                "1 NaN/Inf values (first at point (1,0,1))");
}

// --nan skip with one member NaN at every voxel is the build without that member, bit for bit
// (same samples per voxel, same global range for the σ floor, same GMM streams).
TEST(BuildModel, NanSkipWithAWholeMemberMissingIsTheBuildWithoutIt) {
    const Ensemble e = makeEnsemble({9, 8, 7}, 12, 6);
    Ensemble withNan = e;
    for (std::size_t v = 0; v < e.grid.pointCount(); ++v)
        withNan.member(5)[v] = std::numeric_limits<float>::quiet_NaN();
    Ensemble without = e;
    without.members = 11;
    without.values.clear();
    for (int m = 0; m < e.members; ++m)
        if (m != 5)
            without.values.insert(without.values.end(), e.member(m),
                                  e.member(m) + e.grid.pointCount());
    BuildOptions opt;
    opt.nan = NanPolicy::Skip;
    BuildReport rep;
    const ModelVolume a = buildModel(withNan, opt, &rep);
    const ModelVolume b = buildModel(without, BuildOptions{});
    EXPECT_EQ(a.mean, b.mean);
    EXPECT_EQ(a.stddev, b.stddev);
    EXPECT_EQ(a.min, b.min);
    EXPECT_EQ(a.max, b.max);
    EXPECT_EQ(a.quantiles, b.quantiles);
    EXPECT_EQ(a.iqr, b.iqr);
    EXPECT_EQ(a.gmm, b.gmm);
    EXPECT_EQ(rep.nonFiniteSamples, e.grid.pointCount());
    EXPECT_EQ(rep.voxelsWithNonFinite, e.grid.pointCount());
    EXPECT_EQ(rep.fewestFiniteSamples, 11);
    EXPECT_EQ(a.samplesPerVoxel, 12);  // the member count
}

// Scattered NaN/Inf: each voxel's statistics are those of its finite samples alone, the GMM
// of a voxel with fewer finite samples than K has at most that many components, and voxels
// without NaN are untouched.
TEST(BuildModel, NanSkipUsesEachVoxelsFiniteSamples) {
    const Ensemble e = makeEnsemble({6, 5, 4}, 6, 7);
    Ensemble nan = e;
    const float kNan = std::numeric_limits<float>::quiet_NaN();
    const float kInf = std::numeric_limits<float>::infinity();
    const std::size_t a = e.grid.index(1, 2, 3), b = e.grid.index(0, 0, 0),
                      c = e.grid.index(5, 4, 1);
    nan.member(2)[a] = kNan;
    nan.member(0)[b] = -kInf;
    for (int m = 0; m < 4; ++m) nan.member(m)[c] = m % 2 ? kNan : kInf;  // 2 finite of 6
    BuildOptions opt;
    opt.nan = NanPolicy::Skip;
    const ModelVolume m = buildModel(nan, opt);
    const ModelVolume ref = buildModel(e, BuildOptions{});
    for (std::size_t v = 0; v < e.grid.pointCount(); ++v) {
        std::vector<float> s;
        for (float x : samplesOf(nan, v))
            if (std::isfinite(x)) s.push_back(x);
        std::sort(s.begin(), s.end());
        const std::size_t n = s.size();
        double mean = 0.0;
        for (float x : s) mean += x;
        mean /= static_cast<double>(n);
        double ss = 0.0;
        for (float x : s) ss += (x - mean) * (x - mean);
        EXPECT_NEAR(m.mean[v], mean, 1e-5 * (1.0 + std::abs(mean))) << v;
        EXPECT_NEAR(m.stddev[v], std::sqrt(ss / static_cast<double>(n - 1)), 1e-5) << v;
        EXPECT_EQ(m.min[v], s.front());
        EXPECT_EQ(m.max[v], s.back());
        for (int j = 0; j <= 8; ++j)
            EXPECT_NEAR(m.quantiles[v * 9 + static_cast<std::size_t>(j)],
                        static_cast<double>(numpyQuantile(s, j / 8.0L)), 1e-5)
                << v;
        double piSum = 0.0, mixMean = 0.0;
        int used = 0;
        for (int k = 0; k < 4; ++k) {
            const double pi = m.gmm[v * 12 + static_cast<std::size_t>(k)];
            piSum += pi;
            mixMean += pi * m.gmm[v * 12 + 4 + static_cast<std::size_t>(k)];
            used += pi > 0.0 ? 1 : 0;
        }
        EXPECT_NEAR(piSum, 1.0, 1e-6);
        EXPECT_LE(used, static_cast<int>(n));
        EXPECT_NEAR(mixMean, mean, 1e-3 * (1.0 + std::abs(mean))) << v;  // EM keeps the mean
        if (v != a && v != b && v != c) {
            for (int k = 0; k < 12; ++k)
                EXPECT_EQ(m.gmm[v * 12 + static_cast<std::size_t>(k)],
                          ref.gmm[v * 12 + static_cast<std::size_t>(k)]);
        }
    }
}

TEST(BuildModel, NanSkipNeedsTwoFiniteSamplesAtEveryVoxel) {
    Ensemble e = makeEnsemble({4, 4, 4}, 5, 8);
    for (int m = 0; m < 5; ++m) {
        e.member(m)[e.grid.index(3, 3, 3)] = std::numeric_limits<float>::quiet_NaN();
        if (m > 0) e.member(m)[e.grid.index(1, 2, 3)] = std::numeric_limits<float>::quiet_NaN();
    }
    BuildOptions opt;
    opt.nan = NanPolicy::Skip;
    try {
        buildModel(e, opt);
        ADD_FAILURE() << "no error";
    } catch (const UdvrError& err) {
        EXPECT_NE(std::string(err.what()).find("voxel (1,2,3) has 1 of 5 (2 voxels have"),
                  std::string::npos)
            << err.what();
    }
    // Bricks: the finite values of each brick; a brick of NaN is the error.
    ScalarField f;
    f.grid.dims = {4, 4, 2};
    for (int i = 0; i < 32; ++i) f.values.push_back(static_cast<float>(i % 5));
    f.values[f.grid.index(0, 0, 0)] = std::numeric_limits<float>::quiet_NaN();
    const ModelVolume m = buildModelDownsampled(f, 2, opt);
    std::vector<float> brick;
    for (int z = 0; z < 2; ++z)
        for (int y = 0; y < 2; ++y)
            for (int x = 0; x < 2; ++x)
                if (x + y + z > 0) brick.push_back(f.values[f.grid.index(x, y, z)]);
    std::sort(brick.begin(), brick.end());
    EXPECT_EQ(m.min[0], brick.front());
    EXPECT_EQ(m.max[0], brick.back());
    for (int z = 0; z < 2; ++z)
        for (int y = 2; y < 4; ++y)
            for (int x = 2; x < 4; ++x)
                f.values[f.grid.index(x, y, z)] = std::numeric_limits<float>::infinity();
    try {
        buildModelDownsampled(f, 2, opt);
        ADD_FAILURE() << "no error";
    } catch (const UdvrError& err) {
        EXPECT_NE(std::string(err.what()).find("brick of reduced voxel (1,1,0) has 0 of 8"),
                  std::string::npos)
            << err.what();
    }
    EXPECT_EQ(parseNanPolicy("skip"), NanPolicy::Skip);
    EXPECT_THROW(parseNanPolicy("ignore"), UdvrError);
}

}  // namespace udvr
