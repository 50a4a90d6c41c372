// The render gate of udvr serve: one render at a time, the newest request of a channel wins.
#include "udvr/serve/render_gate.h"

#include <gtest/gtest.h>

#include <thread>

#include "udvr/render/render.h"

namespace udvr::serve {
namespace {

// A render that runs until it is cancelled (as a frame stops between tiles), then throws.
void untilCancelled(const std::atomic<bool>& cancel, std::atomic<bool>& started) {
    started = true;
    while (!cancel.load()) std::this_thread::yield();
    throw RenderCancelled();
}

TEST(RenderGate, ANewerRequestCancelsTheRunningOne) {
    RenderGate gate;
    std::atomic<bool> started{false};
    bool firstDone = true;
    std::thread first([&] {
        firstDone = gate.run("main", std::nullopt,
                             [&](const std::atomic<bool>& c) { untilCancelled(c, started); });
    });
    while (!started) std::this_thread::yield();
    bool ran = false;
    EXPECT_TRUE(gate.run("main", std::nullopt, [&](const std::atomic<bool>&) { ran = true; }));
    first.join();
    EXPECT_FALSE(firstDone);
    EXPECT_TRUE(ran);
    const RenderGate::Stats s = gate.stats();
    EXPECT_EQ(s.cancelled, 1u);
    EXPECT_EQ(s.completed, 1u);
    EXPECT_EQ(s.running, 0);
    EXPECT_EQ(s.waiting, 0);
}

TEST(RenderGate, OtherChannelsWaitTheirTurnWithoutCancelling) {
    RenderGate gate;
    std::atomic<bool> started{false}, release{false};
    std::thread first([&] {
        EXPECT_TRUE(gate.run("a", std::nullopt, [&](const std::atomic<bool>& cancel) {
            started = true;
            while (!release) std::this_thread::yield();
            EXPECT_FALSE(cancel.load());
        }));
    });
    while (!started) std::this_thread::yield();
    std::thread second(
        [&] { EXPECT_TRUE(gate.run("b", std::nullopt, [](const std::atomic<bool>&) {})); });
    while (gate.stats().waiting == 0) std::this_thread::yield();
    release = true;
    first.join();
    second.join();
    EXPECT_EQ(gate.stats().completed, 2u);
}

TEST(RenderGate, AnOlderSeqIsSupersededAtOnce) {
    RenderGate gate;
    EXPECT_TRUE(gate.run("main", 5, [](const std::atomic<bool>&) {}));
    bool ran = false;
    EXPECT_FALSE(gate.run("main", 3, [&](const std::atomic<bool>&) { ran = true; }));
    EXPECT_FALSE(ran);
    EXPECT_TRUE(gate.run("main", 5, [](const std::atomic<bool>&) {}));  // the same seq again
    EXPECT_EQ(gate.stats().superseded, 1u);
}

TEST(RenderGate, AnErrorIsPassedOnAndTheGateStaysOpen) {
    RenderGate gate;
    EXPECT_THROW(gate.run("main", std::nullopt,
                          [](const std::atomic<bool>&) { throw std::runtime_error("bad"); }),
                 std::runtime_error);
    EXPECT_TRUE(gate.run("main", std::nullopt, [](const std::atomic<bool>&) {}));
    EXPECT_EQ(gate.stats().running, 0);
}

// Issue 34, item 7: before, the 65th channel name failed until a restart.
TEST(RenderGate, ANewChannelEvictsTheLeastRecentlyUsedIdleOne) {
    RenderGate gate;
    for (int k = 0; k < 200; ++k)
        EXPECT_TRUE(
            gate.run("c" + std::to_string(k), std::nullopt, [](const std::atomic<bool>&) {}));
    EXPECT_EQ(gate.stats().channels, RenderGate::kMaxChannels);
    EXPECT_EQ(gate.stats().evicted, 200 - RenderGate::kMaxChannels);
}

TEST(RenderGate, AChannelWithARequestUnderWayIsNotEvicted) {
    RenderGate gate;
    std::atomic<bool> started{false}, release{false};
    std::thread busy([&] {  // the oldest channel, but in use
        EXPECT_TRUE(gate.run("busy", 7, [&](const std::atomic<bool>&) {
            started = true;
            while (!release) std::this_thread::yield();
        }));
    });
    while (!started) std::this_thread::yield();
    // Requests whose clients have already gone: each makes its channel, gives up at once, and
    // leaves it idle; 100 of them evict idle channels only.
    const auto gone = std::make_shared<std::atomic<bool>>(true);
    for (int k = 0; k < 100; ++k)
        EXPECT_FALSE(gate.run(
            "x" + std::to_string(k), std::nullopt, [](const std::atomic<bool>&) {}, gone));
    release = true;
    busy.join();
    EXPECT_FALSE(gate.run("busy", 6, [](const std::atomic<bool>&) {}));  // its seq kept: in order
    EXPECT_EQ(gate.stats().channels, RenderGate::kMaxChannels);
}

// Issue 34, item 6: a request whose client has gone gives up waiting, or stops rendering.
TEST(RenderGate, ARequestWhoseClientWentIsCancelled) {
    RenderGate gate;
    std::atomic<bool> started{false}, release{false};
    std::thread first([&] {
        EXPECT_TRUE(gate.run("a", std::nullopt, [&](const std::atomic<bool>&) {
            started = true;
            while (!release) std::this_thread::yield();
        }));
    });
    while (!started) std::this_thread::yield();
    auto gone = std::make_shared<std::atomic<bool>>(false);
    bool ran = false;
    std::thread waiting([&] {
        EXPECT_FALSE(gate.run(
            "b", std::nullopt, [&](const std::atomic<bool>&) { ran = true; }, gone));
    });
    while (gate.stats().waiting == 0) std::this_thread::yield();
    *gone = true;  // the client went while waiting
    waiting.join();
    EXPECT_FALSE(ran);
    release = true;
    first.join();
    auto gone2 = std::make_shared<std::atomic<bool>>(false);
    std::atomic<bool> started2{false};
    std::thread running([&] {
        EXPECT_FALSE(gate.run(
            "c", std::nullopt, [&](const std::atomic<bool>& c) { untilCancelled(c, started2); },
            gone2));
    });
    while (!started2) std::this_thread::yield();
    *gone2 = true;  // the client went while rendering
    running.join();
    EXPECT_EQ(gate.stats().abandoned, 2u);
    EXPECT_EQ(gate.stats().running, 0);
}

}  // namespace
}  // namespace udvr::serve
