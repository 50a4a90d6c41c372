#include "udvr/render/frame_estimate.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

namespace udvr {
namespace {

using Clock = std::chrono::steady_clock;

// A frame whose time is a + b·pixels exactly: the fit through the last two probes returns it.
TEST(FrameEstimate, FitsAPlusBTimesPixels) {
    RenderSettings s;
    s.width = 512;
    s.height = 256;
    std::vector<std::array<int, 2>> sizes;
    const auto probe = [&](const RenderSettings& at) {
        sizes.push_back({at.width, at.height});
        return 30.0 + 0.002 * at.width * at.height;
    };
    const FrameEstimate e = estimateFrame(s, false, probe);
    EXPECT_NEAR(e.ms, 30.0 + 0.002 * 512 * 256, 1e-9);
    EXPECT_FALSE(e.lowerBound);
    // A 2x2 warm-up; 1/32 of the sides, then twice and four times that; each twice (quick).
    const std::vector<std::array<int, 2>> expected{{2, 2},   {16, 8},  {16, 8}, {32, 16},
                                                   {32, 16}, {64, 32}, {64, 32}};
    EXPECT_EQ(sizes, expected);
    EXPECT_EQ(e.width, 64);
    EXPECT_EQ(e.height, 32);
}

// gmm-mc: probes draw 4 realizations; the estimate scales by the frame's count.
TEST(FrameEstimate, MonteCarloScalesByRealizations) {
    RenderSettings s;
    s.realizations = 200;
    const FrameEstimate e = estimateFrame(s, true, [](const RenderSettings& at) {
        EXPECT_EQ(at.realizations, 4);
        return 0.001 * at.width * at.height * at.realizations;
    });
    EXPECT_NEAR(e.ms, 0.001 * 512 * 512 * 200, 1e-6);
}

// gmm-mc whose realizations cost 50 ms each to draw at any size (serve's 200 ms probe limit):
// the 2x2 probe measures that part, so the larger probes still run and the fit is exact (one
// 16x16 probe scaled by the pixels alone would say 1024x its 50 ms).
TEST(FrameEstimate, MonteCarloMeasuresThePerRealizationCost) {
    RenderSettings s;
    s.realizations = 200;
    FrameEstimateLimits limits;
    limits.maxProbeMs = 200.0;
    std::vector<int> sides;
    const FrameEstimate e = estimateFrame(
        s, true,
        [&](const RenderSettings& at) {
            sides.push_back(at.width);
            return (50.0 + 0.0001 * at.width * at.height) * at.realizations / 4.0;
        },
        limits);
    EXPECT_NEAR(e.ms, (50.0 + 0.0001 * 512 * 512) * 50.0, 1e-6);
    EXPECT_FALSE(e.lowerBound);
    EXPECT_EQ(sides, (std::vector<int>{2, 2, 16, 16, 32, 32, 64, 64}));  // each twice
    // Draws alone over the limit: the 2x2 probe is all, a lower bound.
    const FrameEstimate slow = estimateFrame(
        s, true, [&](const RenderSettings& at) { return 300.0 + 0.0 * at.width; }, limits);
    EXPECT_TRUE(slow.lowerBound);
    EXPECT_NEAR(slow.ms, 300.0 * 50.0, 1e-9);
}

// No probe over maxProbeMs: a probe of 40 ms stops the series when the limit is 100 ms.
TEST(FrameEstimate, StopsBeforeAProbeOverTheLimit) {
    RenderSettings s;
    int probes = 0;
    FrameEstimateLimits limits;
    limits.maxProbeMs = 100.0;
    const FrameEstimate e = estimateFrame(
        s, false,
        [&](const RenderSettings& at) {
            ++probes;
            return 40.0 * at.width * at.height / 256.0;  // 16x16: 40 ms
        },
        limits);
    // The 2x2 warm-up, the first probe twice, no 32x32 (160 ms > 100); then 2x2 twice (0.625 ms:
    // quick).
    EXPECT_EQ(probes, 5);
    EXPECT_NEAR(e.ms, 40.0 * 1024, 1e-9);
    EXPECT_EQ(e.width, 16);
}

// One probe fits, and most of its time is what a frame costs at any size (a 2D TF's tables:
// serve saw 72 ms for 16² of a 0.2 s 512² frame, estimated 74 s from the pixels alone): the 2x2
// probe measures that part, and the estimate is the line through the two.
TEST(FrameEstimate, OneProbeWithAFixedCostGetsATwoByTwoProbe) {
    RenderSettings s;  // 512x512
    FrameEstimateLimits limits;
    limits.maxProbeMs = 200.0;
    std::vector<int> sides;
    const FrameEstimate e = estimateFrame(
        s, false,
        [&](const RenderSettings& at) {
            sides.push_back(at.width);
            return 70.0 + 0.0005 * at.width * at.height;
        },
        limits);
    // The 2x2 warm-up, 16² twice (the first probe), then 2x2 once (4 × its 70 ms is over the
    // limit).
    EXPECT_EQ(sides, (std::vector<int>{2, 16, 16, 2}));
    EXPECT_NEAR(e.ms, 70.0 + 0.0005 * 512 * 512, 1e-9);
    EXPECT_FALSE(e.lowerBound);
    EXPECT_EQ(e.width, 16);
}

// A frame that builds tables once (here 1.5 s, then reused) and then costs 0.4 ms a pixel, at
// 128² with render's 1 s probe limit: the 2x2 warm-up pays the
// build, so the 4x4 probe (1/32 of the side) is warm and the fit exact. Without it the 4x4
// probe took 1506 ms (over the limit: not run again) and the line through it and a warm 2x2
// probe (1.6 ms) said 1452 s.
TEST(FrameEstimate, TablesBuiltOnceAreNotFitted) {
    RenderSettings s;
    s.width = s.height = 128;
    bool built = false;
    std::vector<int> sides;
    const FrameEstimate e = estimateFrame(s, false, [&](const RenderSettings& at) {
        sides.push_back(at.width);
        const double build = built ? 0.0 : 1500.0;
        built = true;
        return build + 0.4 * at.width * at.height;
    });
    EXPECT_NEAR(e.ms, 0.4 * 128 * 128, 1e-6);
    EXPECT_FALSE(e.lowerBound);
    EXPECT_EQ(sides, (std::vector<int>{2, 4, 4, 8, 8, 16, 16}));
}

// Tables built as samples first need them: a probe's first run
// builds those its pixels need (here 5 ms for each of pixels/4 levels), so each larger probe's
// first run costs more than its pixels; its second run is the frame's cost per pixel (0.4 ms).
// The 16² probe's first run (342 ms) is over a quarter of the 1 s limit: it runs again anyway,
// and the fit is exact. Fitting that first run (the probes that were not "quick" ran once) said
// 21 s for this 6.6 s frame.
TEST(FrameEstimate, TablesBuiltAsNeededAreNotFitted) {
    RenderSettings s;
    s.width = s.height = 128;
    int levels = 0;
    const FrameEstimate e = estimateFrame(s, false, [&](const RenderSettings& at) {
        const int pixels = at.width * at.height;
        const int built = std::max(0, pixels / 4 - levels);
        levels = std::max(levels, pixels / 4);
        return 5.0 * built + 0.4 * pixels;
    });
    EXPECT_NEAR(e.ms, 0.4 * 128 * 128, 1e-6);
}

// The deadline cancels a probe that would run for ever: the estimate is a lower bound from the
// time spent, and the probes stop within the deadline (plus the watcher's 5 ms poll).
TEST(FrameEstimate, DeadlineCancelsAndGivesALowerBound) {
    RenderSettings s;
    FrameEstimateLimits limits;
    limits.deadlineMs = 60.0;
    const auto started = Clock::now();
    const FrameEstimate e = estimateFrame(
        s, false,
        [](const RenderSettings& at) -> double {
            while (!at.cancel->load()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
            throw RenderCancelled();
        },
        limits);
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - started).count();
    EXPECT_TRUE(e.lowerBound);
    EXPECT_GE(ms, 60.0);
    EXPECT_LT(ms, 60.0 + 200.0);  // generous for a loaded machine
    // The probes' time is the deadline's; the estimate at least the time spent on the cancelled
    // probe (the 2x2 warm-up, which starts once the deadline's watcher runs: a frame is no
    // quicker than a probe of it).
    EXPECT_GE(e.probeMs, 60.0);
    EXPECT_GT(e.ms, 0.0);
    EXPECT_LE(e.ms, e.probeMs);
}

// The caller's own cancel flag is not a deadline: its RenderCancelled passes through.
TEST(FrameEstimate, CallersCancelPassesThrough) {
    std::atomic<bool> cancel{true};
    RenderSettings s;
    s.cancel = &cancel;
    FrameEstimateLimits limits;
    limits.deadlineMs = 10'000.0;
    EXPECT_THROW(estimateFrame(
                     s, false,
                     [](const RenderSettings& at) -> double {
                         while (!at.cancel->load())
                             std::this_thread::sleep_for(std::chrono::milliseconds(1));
                         throw RenderCancelled();
                     },
                     limits),
                 RenderCancelled);
}

// Larger probes no slower than smaller ones (a per-frame cost, and load): no negative per-pixel
// part; the frame costs the probes' mean.
TEST(FrameEstimate, NoSlowerLargerProbesGiveAPerFrameCost) {
    RenderSettings s;  // 512x512: probes 16², 32², 64²
    const FrameEstimate e = estimateFrame(
        s, false, [](const RenderSettings& at) { return at.width == 64 ? 8.0 : 10.0; });
    EXPECT_NEAR(e.ms, (10.0 + 10.0 + 8.0) / 3.0, 1e-9);
}

// Superlinear probes would fit a negative per-frame part: a = 0 and b through the origin, by least
// squares (NumPy: np.linalg.lstsq([[256], [1024], [4096]], [1, 1, 50])).
TEST(FrameEstimate, SuperlinearProbesGiveNoNegativePart) {
    RenderSettings s;
    const FrameEstimate e = estimateFrame(
        s, false, [](const RenderSettings& at) { return at.width == 64 ? 50.0 : 1.0; });
    EXPECT_NEAR(e.ms, 3019.4871794871797, 1e-6);
}

// Three noisy probes of 5 + 0.01·pixels: the least-squares line through all three.
TEST(FrameEstimate, LeastSquaresOverTheProbes) {
    RenderSettings s;
    const FrameEstimate e = estimateFrame(s, false, [](const RenderSettings& at) {
        const double p = at.width * at.height;
        return 5.0 + 0.01 * p + (at.width == 32 ? 3.0 : 0.0);
    });
    // NumPy: b, a = np.polyfit([256, 1024, 4096], [7.56, 18.24, 45.96], 1); a + b·512².
    EXPECT_NEAR(e.ms, 2554.7971428571436, 1e-6);
}

// A frame no larger than the smallest probe is not estimated.
TEST(FrameEstimate, NoProbeForATinyFrame) {
    RenderSettings s;
    s.width = s.height = 2;
    int probes = 0;
    const FrameEstimate e = estimateFrame(s, false, [&](const RenderSettings&) {
        ++probes;
        return 1.0;
    });
    EXPECT_EQ(probes, 0);
    EXPECT_EQ(e.ms, 0.0);
}

}  // namespace
}  // namespace udvr
