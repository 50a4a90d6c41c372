#include "udvr/util/progress.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>

namespace udvr {

bool ProgressBar::enabled() { return std::getenv("UDVR_NO_PROGRESS") == nullptr; }

double ProgressBar::lineSeconds() {
    const char* every = std::getenv("UDVR_PROGRESS_EVERY");
    if (every == nullptr) return 10.0;
    char* end = nullptr;
    const double s = std::strtod(every, &end);
    return end != every && *end == '\0' && s > 0.0 && s < 1e6 ? s : 10.0;
}

ProgressBar::ProgressBar(std::string label, std::size_t total, double showAfterSeconds, bool draw)
    : label_(std::move(label)),
      total_(total == 0 ? 1 : total),
      start_(std::chrono::steady_clock::now()),
      enabled_(draw && enabled()),
      terminal_(isatty(fileno(stderr)) != 0),
      lineNs_(static_cast<long long>(lineSeconds() * 1e9)),
      // Lines (not a terminal): the first after lineSeconds() at the earliest.
      showAfterNs_(terminal_ ? static_cast<long long>(showAfterSeconds * 1e9)
                             : std::max(static_cast<long long>(showAfterSeconds * 1e9), lineNs_)) {}

ProgressBar::~ProgressBar() { finish(); }

void ProgressBar::advance(std::size_t units) {
    if (cancelled_.load(std::memory_order_relaxed)) throw ProgressCancelled();
    std::size_t done = done_.fetch_add(units) + units;
    if (!enabled_) return;
    long long now = std::chrono::duration_cast<std::chrono::nanoseconds>(
                        std::chrono::steady_clock::now() - start_)
                        .count();
    if (now < showAfterNs_) return;
    long long last = lastDrawNs_.load();
    const long long gap = terminal_ ? 100'000'000 : lineNs_;
    if (last != 0 && now - last < gap) return;
    if (!terminal_ && done >= total_) return;  // lines: the end needs no line of its own
    if (!lastDrawNs_.compare_exchange_strong(last, now)) return;
    draw(done);
}

void ProgressBar::draw(std::size_t done) {
    std::lock_guard<std::mutex> lock(drawMutex_);
    if (finished_) return;
    double frac = static_cast<double>(done) / static_cast<double>(total_);
    if (frac > 1.0) frac = 1.0;
    const int width = 30;
    int filled = static_cast<int>(frac * width);
    double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    // The time left at the rate so far (unknown before 1 % is done).
    const double left = frac >= 0.01 ? elapsed * (1.0 - frac) / frac : -1.0;
    char eta[48] = "";
    if (left >= 0.0 && frac < 1.0) std::snprintf(eta, sizeof eta, ", about %.0f s left", left);
    if (!terminal_) {
        std::fprintf(stderr, "%s: %.0f %% done after %.0f s%s\n", label_.c_str(), 100.0 * frac,
                     elapsed, eta);
        std::fflush(stderr);
        return;  // no line to end
    }
    std::string bar(static_cast<std::size_t>(filled), '#');
    bar.append(static_cast<std::size_t>(width - filled), '.');
    std::fprintf(stderr, "\r%s [%s] %5.1f%% %6.1fs%-24s", label_.c_str(), bar.c_str(), 100.0 * frac,
                 elapsed, eta);
    std::fflush(stderr);
    drawn_ = true;
}

void ProgressBar::finish() {
    if (!enabled_) return;
    {
        std::lock_guard<std::mutex> lock(drawMutex_);
        if (!drawn_) {  // never shown (quicker than showAfterSeconds): stay silent
            finished_ = true;
            return;
        }
    }
    draw(total_);
    std::lock_guard<std::mutex> lock(drawMutex_);
    if (finished_) return;
    finished_ = true;
    std::fprintf(stderr, "\n");
    std::fflush(stderr);
}

}  // namespace udvr
