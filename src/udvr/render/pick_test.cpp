// firstVisibleSample (udvr serve's click probe) and a cancelled frame.
#include <gtest/gtest.h>

#include <atomic>

#include "udvr/render/render.h"
#include "udvr/stats/model_volume.h"

namespace udvr {
namespace {

// A 16³ field on [0, 15]³ whose value is its x index: the TF shows values ≥ 8 only.
ModelVolume rampModel() {
    ScalarField f;
    f.grid.dims = {16, 16, 16};
    f.grid.spacing = {1.0, 1.0, 1.0};
    f.grid.origin = {0.0, 0.0, 0.0};
    f.values.resize(f.grid.pointCount());
    for (int k = 0; k < 16; ++k)
        for (int j = 0; j < 16; ++j)
            for (int i = 0; i < 16; ++i) f.values[(k * 16 + j) * 16 + i] = static_cast<float>(i);
    return modelFromField(f);
}

TransferFunction1D stepTf() {
    TransferFunction1D tf;
    tf.colorX = {0.0, 15.0};
    tf.color = {{{1.0, 0.0, 0.0}}, {{1.0, 0.0, 0.0}}};
    tf.opacityX = {0.0, 7.9, 8.0, 15.0};
    tf.opacity = {0.0, 0.0, 0.5, 0.5};
    return tf;
}

// Looking down −x from +x: the ray meets the visible half (x ≥ 8) at once; from −x it first
// crosses the clear half, so the first visible sample lies at x ≈ 8.
TEST(FirstVisibleSample, IsTheFirstSampleOfTheRayWithOpacity) {
    const ModelVolume m = rampModel();
    RenderSettings s;
    s.width = s.height = 9;
    s.camera.focalPoint = {7.5, 7.5, 7.5};
    s.camera.position = {-40.0, 7.5, 7.5};
    const auto hit = firstVisibleSample(m, ModelKind::Mean, stepTf(), s, 4, 4);
    ASSERT_TRUE(hit.has_value());
    EXPECT_GE((*hit)[0], 7.9);
    EXPECT_LE((*hit)[0], 7.9 + 0.5 + 1e-6);  // within one step (Δ = ½ spacing) of the edge
    s.camera.position = {40.0, 7.5, 7.5};
    const auto front = firstVisibleSample(m, ModelKind::Mean, stepTf(), s, 4, 4);
    ASSERT_TRUE(front.has_value());
    EXPECT_GE((*front)[0], 15.0 - 0.5);  // the first sample inside the box
    // A pixel whose ray misses the box.
    s.camera.viewAngleDeg = 170.0;
    EXPECT_FALSE(firstVisibleSample(m, ModelKind::Mean, stepTf(), s, 0, 0).has_value());
    EXPECT_THROW(firstVisibleSample(m, ModelKind::Mean, stepTf(), s, 9, 0), UdvrError);
}

TEST(RenderCancel, ACancelledFrameThrowsAndAnUncancelledOneRenders) {
    const ModelVolume m = rampModel();
    RenderSettings s;
    s.width = s.height = 8;
    s.camera.focalPoint = {7.5, 7.5, 7.5};
    s.camera.position = {-40.0, 7.5, 7.5};
    std::atomic<bool> cancel{true};
    s.cancel = &cancel;
    EXPECT_THROW(renderVolume(m, ModelKind::Mean, stepTf(), s), RenderCancelled);
    cancel = false;
    const ImageRgba image = renderVolume(m, ModelKind::Mean, stepTf(), s);
    EXPECT_GT(image.pixel(4, 4)[3], 0.5f);
}

}  // namespace
}  // namespace udvr
