#include "udvr/eval/probe_plot.h"

#include <gtest/gtest.h>

#include "udvr/classify/classify_test_util.h"
#include "udvr/classify/probe.h"

namespace udvr {
namespace {

// Every model's probed distribution plots at the size asked for (at least 200 × 150), with ink
// on it.
TEST(ProbePlot, EveryModelsDistributionPlots) {
    CounterRng rng(61, 0, 0);
    const ModelVolume m = testing::randomModel(rng, {3, 2, 2}, 8);
    const auto r = modelDataRange(m);
    const TransferFunction1D tf = testing::randomTf(rng, r.first, r.second);
    for (ModelKind kind : allModelKinds()) {
        if (kind == ModelKind::GmmMc) continue;  // no distribution at a point (screen space)
        const ProbeResult p = probeModel(m, kind, tf, {1.25, 0.5, 1.0});
        const ImageRgba im = renderProbePlot(p, tf, 320, 200);
        ASSERT_EQ(im.width, 320) << modelName(kind);
        ASSERT_EQ(im.height, 200) << modelName(kind);
        int dark = 0;  // pixels well off the white background: axes, curves, labels
        for (int y = 0; y < im.height; ++y)
            for (int x = 0; x < im.width; ++x) dark += im.pixel(x, y)[0] < 0.5f;
        EXPECT_GT(dark, 100) << modelName(kind);
    }
}

}  // namespace
}  // namespace udvr
