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
            // The first probe runs again (its first run built the skipping and kernel tables
            // the frame reuses), as do quick ones; the faster run counts (other work on the
            // machine only ever adds time).
            if (runs.empty() ? ms <= limits.maxProbeMs : 4.0 * ms <= limits.maxProbeMs)
                ms = std::min(ms, probe(at));
        } catch (const RenderCancelled&) {
            if (s.cancel && s.cancel->load()) throw;  // the caller's, not the deadline
            const double spent =
                std::chrono::duration<double, std::milli>(Clock::now() - started).count();
            e.probeMs += spent;
            e.width = at.width;
            e.height = at.height;
            // A frame takes at least as long as a smaller probe of it (not the probe's time
            // scaled by the pixels: a gmm-mc realization's voxels cost the same at any size).
            e.ms = std::max(e.ms, spent * perFrame);
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
    // Least squares over the probes of t = a + b·pixels with a, b >= 0 (all the probes, not the
    // last two: on a loaded machine one probe's time can be off by 2x). One probe: b·pixels.
    double ms = 0.0;
    if (runs.size() == 1) {
        ms = runs[0][1] * full / runs[0][0];
    } else {
        const double n = static_cast<double>(runs.size());
        double pm = 0.0, tm = 0.0;
        for (const auto& [p, t] : runs) pm += p / n, tm += t / n;
        double spp = 0.0, spt = 0.0, sp2 = 0.0, sptRaw = 0.0;
        for (const auto& [p, t] : runs) {
            spp += (p - pm) * (p - pm);
            spt += (p - pm) * (t - tm);
            sp2 += p * p;
            sptRaw += p * t;
        }
        double slope = spt / spp, a = tm - slope * pm;
        if (slope < 0.0) {  // larger probes no slower: a per-frame cost (gmm-mc's draws)
            slope = 0.0;
            a = tm;
        } else if (a < 0.0) {  // superlinear: through the origin
            a = 0.0;
            slope = sptRaw / sp2;
        }
        ms = a + slope * full;
    }
    e.ms = ms * perFrame;
    return e;
}

}  // namespace udvr
