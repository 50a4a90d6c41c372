#include "udvr/classify/tf_presets.h"

#include <gtest/gtest.h>

#include "udvr/util/check.h"

namespace udvr {
namespace {

TEST(TfPresets, EveryPresetSpansTheRangeWithAnOpacityRampFromTheStart) {
    const auto names = transferFunctionPresetNames();
    ASSERT_GE(names.size(), 4u);
    EXPECT_EQ(names.front(), "cool-to-warm");
    for (const std::string& name : names) {
        EXPECT_TRUE(isTransferFunctionPreset(name));
        const TransferFunction1D tf = transferFunctionPreset(name, {10.0, 30.0}, 14.0);
        EXPECT_EQ(tf.domain().first, 10.0) << name;
        EXPECT_EQ(tf.domain().second, 30.0) << name;
        EXPECT_EQ(tf.opacityAt(9.0), 0.0);
        EXPECT_EQ(tf.opacityAt(14.0), 0.0);
        EXPECT_DOUBLE_EQ(tf.opacityAt(22.0), 0.25);  // halfway up the ramp 14 → 30
        EXPECT_DOUBLE_EQ(tf.opacityAt(30.0), 0.5);
        EXPECT_DOUBLE_EQ(tf.opacityAt(99.0), 0.5);
        const auto ranges = tf.nonZeroOpacityRanges();
        ASSERT_EQ(ranges.size(), 1u);
        EXPECT_EQ(ranges[0].first, 14.0);
    }
    // cool-to-warm's middle is its published grey.
    const auto mid = transferFunctionPreset("cool-to-warm", {0.0, 2.0}, 1.0).colorAt(1.0);
    EXPECT_NEAR(mid[0], 0.865003, 1e-12);
    EXPECT_NEAR(mid[2], 0.865003, 1e-12);
}

TEST(TfPresets, RampStartIsClampedAndUnknownNamesAreListed) {
    const TransferFunction1D low = transferFunctionPreset("viridis", {0.0, 1.0}, -5.0);
    EXPECT_DOUBLE_EQ(low.opacityAt(0.5), 0.25);
    const TransferFunction1D top = transferFunctionPreset("grayscale", {0.0, 1.0}, 7.0);
    EXPECT_DOUBLE_EQ(top.opacityAt(0.5), 0.25);  // start at the top: ramp over the range
    EXPECT_FALSE(isTransferFunctionPreset("Viridis"));
    try {
        transferFunctionPreset("jet", {0.0, 1.0}, 0.5);
        FAIL() << "no throw";
    } catch (const UdvrError& e) {
        EXPECT_NE(std::string(e.what()).find("cool-to-warm"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace udvr
