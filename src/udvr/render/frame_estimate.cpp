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

#include "udvr/util/watcher_thread.h"

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
    ~Deadline() { stopWatcher(mutex_, stop_, wake_, watcher_); }
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
    const auto begun = Clock::now();
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
    // Sides: 1/32 of the frame's (at least 2 pixels), then twice and four times that. gmm-mc
    // first probes 2x2: its time is what a realization costs at any size (drawing it over the
    // voxels), which can be most of a 1/32 probe's; without it, one 16² probe scaled by the
    // pixels gave 3575 s for a 54 s frame (serve) and 12995 s for a ~60 s one (the tangle's
    // 64³, 512²). Not for frames under 256²: fitted between 2x2 and 4x4 probes, the load's noise
    // gave 2183 s for a 0.75 s frame of 128².
    const int w0 = std::max(2, s.width / 32), h0 = std::max(2, s.height / 32);
    std::vector<std::array<int, 2>> sides;
    if (monteCarlo && w0 * h0 >= 64) sides.push_back({2, 2});
    for (int k : {1, 2, 4}) sides.push_back({w0 * k, h0 * k});
    double fixedMs = 0.0;  // the 2x2 gmm-mc probe's time
    // A 2x2 frame first, its time not fitted (gmm-mc's first 2x2 probe does it too): it builds
    // what a frame builds once and later frames reuse (the skipping tables, a TF2's tables), so
    // that no probe's first run carries it (a first probe over maxProbeMs runs once: fitted
    // with a warm 2x2 probe, its build said 1452 s for a 6.6 s frame, FrameEstimate tests).
    if (sides.front() != std::array<int, 2>{2, 2} && sides.front()[0] < s.width &&
        sides.front()[1] < s.height) {
        at.width = at.height = 2;
        const auto started = Clock::now();
        try {
            probe(at);
        } catch (const RenderCancelled&) {
            if (s.cancel && s.cancel->load()) throw;
            const auto now = Clock::now();
            e.probeMs = std::chrono::duration<double, std::milli>(now - begun).count();
            e.width = e.height = 2;
            // A frame takes at least as long as a probe of it.
            e.ms = std::chrono::duration<double, std::milli>(now - started).count() * perFrame;
            e.lowerBound = true;
            return e;
        }
        e.probeMs = std::chrono::duration<double, std::milli>(Clock::now() - started).count();
    }
    const double warmMs = e.probeMs;  // the warm-up's: what a frame builds once, at least
    for (const auto& [pw, ph] : sides) {
        at.width = pw;
        at.height = ph;
        if (at.width >= s.width || at.height >= s.height) break;
        const double pixels = static_cast<double>(at.width) * at.height;
        const auto started = Clock::now();
        double ms = 0.0;
        try {
            ms = probe(at);
            // Every probe within the limit runs again and the faster run counts: its first run
            // may have built what the frame reuses (tables built as samples first need them),
            // and other work on the machine only ever adds time.
            if (ms <= limits.maxProbeMs) ms = std::min(ms, probe(at));
        } catch (const RenderCancelled&) {
            if (s.cancel && s.cancel->load()) throw;  // the caller's, not the deadline
            const double spent =
                std::chrono::duration<double, std::milli>(Clock::now() - started).count();
            e.probeMs += spent;
            e.width = at.width;
            e.height = at.height;
            // A frame takes at least as long as a smaller probe of it with what the warm-up
            // built once (not the probe's time scaled by the pixels: a gmm-mc realization's
            // voxels cost the same at any size).
            e.ms = std::max(e.ms, (warmMs + spent) * perFrame);
            e.lowerBound = true;
            return e;
        }
        runs.push_back({pixels, ms});
        e.width = at.width;
        e.height = at.height;
        e.probeMs += ms;
        if (monteCarlo && runs.size() == 1 && sides.size() == 4) {
            fixedMs = ms;  // the next probe: its per-realization part and ~4x its pixels' part
            if (ms > limits.maxProbeMs) break;
            continue;
        }
        // The next probe has 4x the pixels: it would take too long.
        if (fixedMs + 4.0 * std::max(ms - fixedMs, 0.0) > limits.maxProbeMs) break;
    }
    // One probe of the frame's pixels (the next, 4x larger, would be over the limit): its time
    // can be mostly what a frame costs at any size — with a 2D TF the raster's tables, ~15 ms
    // on a quiet machine and 50-120 ms in `udvr serve` under load, which scaled by the pixels
    // alone (1024x for 16² of 512²) gave 74 s for a 0.2 s frame. A 2x2 probe measures that
    // part (as gmm-mc's first probe does), and the two are fitted as below.
    if (runs.size() == 1 && sides.size() == 3 && runs[0][0] > 4.0) {
        at.width = at.height = 2;
        const auto started = Clock::now();
        try {
            double ms = probe(at);
            if (4.0 * ms <= limits.maxProbeMs) ms = std::min(ms, probe(at));
            runs.push_back({4.0, ms});
            e.probeMs += ms;
        } catch (const RenderCancelled&) {
            if (s.cancel && s.cancel->load()) throw;
            // Out of time: a frame takes at least as long as the probe of it.
            e.probeMs += std::chrono::duration<double, std::milli>(Clock::now() - started).count();
            e.ms = runs[0][1] * perFrame;
            e.lowerBound = true;
            return e;
        }
    }
    if (runs.empty()) return e;
    if (runs.size() == 1 && sides.size() == 4) {  // only gmm-mc's 2x2: a frame takes longer
        e.ms = runs[0][1] * perFrame;
        e.lowerBound = true;
        return e;
    }
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
