#include "udvr/util/parallel.h"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <memory>
#include <mutex>

namespace udvr {
namespace {
std::mutex gControlMutex;
std::unique_ptr<tbb::global_control> gControl;  // process-wide limit; constant after setup
int gThreads = 0;
}  // namespace

int maxThreadCount() {
    return kMaxThreadsPerHardwareThread * std::max(tbb::info::default_concurrency(), 1);
}

int setThreadCount(int threads) {
    threads = std::clamp(threads, 0, maxThreadCount());
    std::lock_guard<std::mutex> lock(gControlMutex);
    gControl.reset();
    gThreads = threads;
    if (threads > 0) {
        gControl = std::make_unique<tbb::global_control>(
            tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    }
    return threadCount();
}

int threadCount() {
    if (gThreads > 0) return gThreads;
    return tbb::info::default_concurrency();
}

void parallelForChunks(std::size_t n, std::size_t grain,
                       const std::function<void(std::size_t, std::size_t)>& body) {
    if (n == 0) return;
    if (grain == 0) grain = 1;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain),
                      [&](const tbb::blocked_range<std::size_t>& r) { body(r.begin(), r.end()); });
}

}  // namespace udvr
