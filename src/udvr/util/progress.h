#pragma once
// Progress on stderr: a bar with the time left when stderr is a terminal, otherwise (a log, a
// pipe, a batch job) one line every lineSeconds() with the share done and the time left;
// UDVR_NO_PROGRESS=1 keeps it quiet (the tests).
// Thread-safe: advance() may be called from worker threads.
#include <atomic>
#include <chrono>
#include <cstddef>
#include <mutex>
#include <stdexcept>
#include <string>

namespace udvr {

/// Thrown by ProgressBar::advance once the bar was cancelled: the work stops where it reports.
class ProgressCancelled : public std::runtime_error {
  public:
    ProgressCancelled() : std::runtime_error("cancelled") {}
};

class ProgressBar {
  public:
    /// label: what is being done ("build"); total: units of work (voxels, rows, frames).
    /// Nothing is drawn before `showAfterSeconds` have passed (work that ends sooner stays
    /// silent: e.g. a render frame, which is usually far shorter). `draw` false: never drawn,
    /// only counted (a front end that shows done() its own way: Python's progress callback).
    ProgressBar(std::string label, std::size_t total, double showAfterSeconds = 0.0,
                bool draw = true);
    ~ProgressBar();
    ProgressBar(const ProgressBar&) = delete;
    ProgressBar& operator=(const ProgressBar&) = delete;

    /// Add done units; redraws at most ~10 times per second. Throws ProgressCancelled once
    /// cancel() was called (from whichever thread advances: parallel loops pass it on).
    void advance(std::size_t units = 1);
    /// Ask the work that advances this bar to stop (a front end running it on another thread:
    /// Python's Ctrl-C, a progress callback that raised).
    void cancel() { cancelled_.store(true, std::memory_order_relaxed); }
    /// Draw 100 % and end the line (also done by the destructor).
    void finish();
    /// Units done so far (any thread may read it while others advance).
    std::size_t done() const { return done_.load(std::memory_order_relaxed); }
    /// Units of work in all (at least 1).
    std::size_t total() const { return total_; }
    /// Whether progress is shown at all (UDVR_NO_PROGRESS is unset).
    static bool enabled();
    /// Seconds between two progress lines when stderr is not a terminal: 10, or
    /// UDVR_PROGRESS_EVERY (seconds, > 0) where set.
    static double lineSeconds();

  private:
    void draw(std::size_t done);
    std::string label_;
    std::size_t total_;
    std::atomic<std::size_t> done_{0};
    std::atomic<bool> cancelled_{false};
    std::atomic<long long> lastDrawNs_{0};
    std::chrono::steady_clock::time_point start_;
    std::mutex drawMutex_;
    bool enabled_;
    bool terminal_;  // a redrawn bar; else a line every lineSeconds()
    long long lineNs_;
    long long showAfterNs_;
    bool drawn_ = false;
    bool finished_ = false;
};

}  // namespace udvr
