#include "udvr/render/frame_estimate.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

namespace udvr {
namespace {

using Clock = std::chrono::steady_clock;

// Sets `flag` when the deadline passes or `outer` (the caller's cancel flag) turns true, until
// destroyed; polls `outer` every 5 ms.
class Deadline {
  public:
    Deadline(double ms, const std::atomic<bool>* outer)
        : end_(Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                  std::chrono::duration<double, std::milli>(ms))),
          outer_(outer) {
        watcher_ = std::thread([this] {
            std::unique_lock lock(mutex_);
            while (!stop_) {
                if (Clock::now() >= end_ || (outer_ && outer_->load())) {
                    flag_.store(true);
                    return;
                }
                wake_.wait_for(lock, std::chrono::milliseconds(5));
            }
        });
    }
    ~Deadline() {
        {
            std::lock_guard lock(mutex_);
            stop_ = true;
        }
        wake_.notify_all();
        watcher_.join();
    }
    Deadline(const Deadline&) = delete;
    Deadline& operator=(const Deadline&) = delete;
    const std::atomic<bool>* flag() const { return &flag_; }

  private:
    Clock::time_point end_;
    const std::atomic<bool>* outer_;
    std::atomic<bool> flag_{false};
    std::mutex mutex_;
    std::condition_variable wake_;
    bool stop_ = false;
    std::thread watcher_;
};

}  // namespace

FrameEstimate estimateFrame(const RenderSettings& s, bool monteCarlo,
                            const std::function<double(const RenderSettings&)>& probe,
                            const FrameEstimateLimits& limits) {
    FrameEstimate e;
    RenderSettings at = s;
    double perFrame = 1.0;  // gmm-mc: the frame's realizations per probe realization
    if (monteCarlo && s.realizations > 4) {
        at.realizations = 4;
        perFrame = s.realizations / 4.0;
    }
    const double full = static_cast<double>(s.width) * s.height;
    std::optional<Deadline> deadline;
    if (limits.deadlineMs > 0.0) {
        deadline.emplace(limits.deadlineMs, s.cancel);
        at.cancel = deadline->flag();
    }
    std::vector<std::array<double, 2>> runs;  // (pixels, ms)
    // Sides: 1/32 of the frame's (at least 2 pixels), then twice and four times that.
    const int w0 = std::max(2, s.width / 32), h0 = std::max(2, s.height / 32);
    for (int k : {1, 2, 4}) {
        at.width = w0 * k;
        at.height = h0 * k;
        if (at.width >= s.width || at.height >= s.height) break;
        const double pixels = static_cast<double>(at.width) * at.height;
        const auto started = Clock::now();
        double ms = 0.0;
        try {
            ms = probe(at);
            if (runs.empty() && ms < 100.0) ms = probe(at);  // tables built
        } catch (const RenderCancelled&) {
            if (s.cancel && s.cancel->load()) throw;  // the caller's, not the deadline
            const double spent =
                std::chrono::duration<double, std::milli>(Clock::now() - started).count();
            e.probeMs += spent;
            e.width = at.width;
            e.height = at.height;
            e.ms = std::max(e.ms, spent * full / pixels * perFrame);
            e.lowerBound = true;
            return e;
        }
        runs.push_back({pixels, ms});
        e.width = at.width;
        e.height = at.height;
        e.probeMs += ms;
        if (4.0 * ms > limits.maxProbeMs) break;  // the next would take too long
    }
    if (runs.empty()) return e;
    const auto& [p2, t2] = runs.back();
    double ms = t2 * full / p2;
    if (runs.size() >= 2) {
        const auto& [p1, t1] = runs[runs.size() - 2];
        const double b = std::max(0.0, (t2 - t1) / (p2 - p1));
        const double a = std::max(0.0, t2 - b * p2);
        ms = a + b * full;
    }
    e.ms = ms * perFrame;
    return e;
}

}  // namespace udvr
