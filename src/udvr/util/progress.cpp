#include "udvr/util/progress.h"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>

namespace udvr {

bool ProgressBar::enabled() {
    return isatty(fileno(stderr)) != 0 && std::getenv("UDVR_NO_PROGRESS") == nullptr;
}

ProgressBar::ProgressBar(std::string label, std::size_t total, double showAfterSeconds, bool draw)
    : label_(std::move(label)),
      total_(total == 0 ? 1 : total),
      start_(std::chrono::steady_clock::now()),
      enabled_(draw && enabled()),
      showAfterNs_(static_cast<long long>(showAfterSeconds * 1e9)) {}

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
    if (now - last < 100'000'000 && done < total_) return;
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
    std::string bar(static_cast<std::size_t>(filled), '#');
    bar.append(static_cast<std::size_t>(width - filled), '.');
    std::fprintf(stderr, "\r%s [%s] %5.1f%% %6.1fs", label_.c_str(), bar.c_str(), 100.0 * frac,
                 elapsed);
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
