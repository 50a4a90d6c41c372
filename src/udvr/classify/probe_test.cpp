#include "udvr/classify/probe.h"

#include <gtest/gtest.h>

#include "udvr/classify/classify_test_util.h"
#include "udvr/classify/point_distribution.h"

namespace udvr {
namespace {

TEST(Probe, JsonHoldsTheDistributionAndExpectation) {
    CounterRng rng(61, 0, 0);
    const ModelVolume m = testing::randomModel(rng, {3, 2, 2}, 8);
    const auto r = modelDataRange(m);
    const TransferFunction1D tf = testing::randomTf(rng, r.first, r.second);
    for (ModelKind kind : allModelKinds()) {
        if (kind == ModelKind::GmmMc) {
            EXPECT_THROW(probeModel(m, kind, tf, {1, 0.5, 0.5}), UdvrError);
            continue;
        }
        const ProbeResult p = probeModel(m, kind, tf, {1.25, 0.5, 1.0});
        const auto& j = p.json;
        EXPECT_EQ(j["model"], std::string(modelName(kind)));
        ASSERT_EQ(j["expected_rgba"].size(), 4u);
        EXPECT_NEAR(j["expected_rgba"][3].get<double>(), p.expected.a, 1e-7);
        EXPECT_TRUE(j.contains("value"));
        if (kind == ModelKind::Gaussian || kind == ModelKind::Uniform) {
            EXPECT_TRUE(j.contains("mean") && j.contains("stddev"));
        }
        if (needsQuantiles(kind) || kind == ModelKind::Iqr) {
            EXPECT_TRUE(j.contains("boundaries"));
        }
        if (kind == ModelKind::GmmOrdered) {
            EXPECT_EQ(j["weights"].size(), 3u);
        }
        if (kind == ModelKind::Members) {
            EXPECT_EQ(j["members"], m.memberCount);
            ASSERT_EQ(j["member_values"].size(), static_cast<std::size_t>(m.memberCount));
            EXPECT_LE(j["min"].get<double>(), j["mean"].get<double>());
            EXPECT_LE(j["mean"].get<double>(), j["max"].get<double>());
            // The members' mean at the point is the interpolated mean array ("value").
            EXPECT_NEAR(j["mean"].get<double>(), j["value"].get<double>(), 1e-5);
        }
        // Continuous part + point masses = 1.
        double mass = p.distribution.continuousMass;
        for (double a : p.distribution.atomMass) mass += a;
        EXPECT_NEAR(mass, 1.0, 1e-9) << modelName(kind);
    }
    EXPECT_THROW(probeModel(m, ModelKind::Mean, tf, {2.5, 0, 0}), UdvrError);
}

TEST(Probe, PlainFieldNamesTheModelsItLacksArraysFor) {
    // A field read as a model (one value per voxel) has mean, min, max and a zero stddev: the
    // mean-based models work; the ones needing quantiles, iqr or gmm say to build a model.
    ScalarField f;
    f.grid.dims = {3, 2, 2};
    for (int i = 0; i < 12; ++i) f.values.push_back(static_cast<float>(i));
    const ModelVolume m = modelFromField(f);
    CounterRng rng(5, 0, 0);
    const TransferFunction1D tf = testing::randomTf(rng, 0, 11);
    for (ModelKind kind : allModelKinds()) {
        if (kind == ModelKind::GmmMc) continue;
        const bool plain = kind == ModelKind::Mean || kind == ModelKind::Gaussian ||
                           kind == ModelKind::GaussianExact || kind == ModelKind::Uniform ||
                           kind == ModelKind::UniformFast || kind == ModelKind::UniformExact;
        if (plain) {
            EXPECT_NO_THROW(probeModel(m, kind, tf, {1, 0.5, 0.5})) << modelName(kind);
            continue;
        }
        try {
            probeModel(m, kind, tf, {1, 0.5, 0.5});
            ADD_FAILURE() << modelName(kind) << " probed a plain field";
        } catch (const UdvrError& e) {
            const std::string msg = e.what();
            // members needs the ensemble itself, which no build makes.
            const bool members = kind == ModelKind::Members;
            EXPECT_NE(msg.find(members ? "single field" : "plain field"), std::string::npos) << msg;
            EXPECT_NE(msg.find(members ? "needs an ensemble" : "udvr build"), std::string::npos)
                << msg;
            EXPECT_NE(msg.find(modelName(kind)), std::string::npos) << msg;
        }
    }
}

TEST(PointDistribution, EveryKernelClassifiesAsTheExpectationOverItsDistribution) {
    // One distribution object per model (each kernel's `reconstruct`, distributions.h; a
    // Distribution1D over double and lanes, checked at compile time) and one 1D expectation over
    // any distribution (expectedTfOver, Eq. 3 piece by piece): every kernel's own classification
    // (the double body the renderer's lanes are checked against) equals it. Exact models to
    // 1e−9 (summation order); uniform-fast approximates the box spline's expectation, within
    // its stated 1e−3. Random models (members included), random TFs, and
    // random points of random cells.
    for (int seed = 0; seed < 6; ++seed) {
        CounterRng rng(401 + seed, 0, 0);
        const ModelVolume m = testing::randomModel(rng, {4, 3, 3}, 8);
        const auto range = modelDataRange(m);
        const TransferFunction1D tf = testing::randomTf(rng, range.first, range.second);
        for (ModelKind kind : allModelKinds()) {
            if (kind == ModelKind::GmmMc) continue;
            withKernel(m, kind, tf, [&](const auto& k) {
                [[maybe_unused]] const auto onLanes = [&](const Cell<lanes::Vf>& c) {
                    k.template reconstruct<lanes::Vf>(c, lanes::allTrue<lanes::Vf>(),
                                                      []<Distribution1D D>(const D&) {});
                };
                for (int i = 0; i < 20; ++i) {
                    const Cell<double> cell =
                        cellAt<double>(CellGeometry(m.grid), static_cast<float>(3 * rng.uniform()),
                                       static_cast<float>(2 * rng.uniform()),
                                       static_cast<float>(2 * rng.uniform()));
                    double kernel[4], over[4];
                    k.finish(k.template load<double>(cell, true), kernel);
                    k.template reconstruct<double>(cell, true, []<Distribution1D D>(const D&) {});
                    PointDistribution d;
                    distributionAt(k, cell, d);
                    double mass = d.continuousMass();
                    for (const auto& a : d.atoms) mass += a.mass;
                    ASSERT_NEAR(mass, 1.0, 1e-12) << modelName(kind);
                    expectedTfOver(k.tfExact, d, over);
                    const double tol =
                        kind == ModelKind::UniformFast || kind == ModelKind::Uniform ? 1e-3 : 1e-9;
                    for (int ch = 0; ch < 4; ++ch)
                        ASSERT_NEAR(kernel[ch], over[ch], tol)
                            << modelName(kind) << " seed " << seed << " channel " << ch;
                }
            });
        }
    }
}

}  // namespace
}  // namespace udvr
