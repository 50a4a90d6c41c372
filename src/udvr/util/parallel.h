#pragma once
// Parallel loops over index ranges, backed by oneTBB. The thread count is global and set
// once by the front end (--threads); 0 means all cores.
#include <cstddef>
#include <functional>

namespace udvr {

/// At most this many worker threads per hardware thread: more only cost memory (each thread a
/// stack and TBB's arena slots; set_threads(10**9) held 7.9 GB, issue 34).
inline constexpr int kMaxThreadsPerHardwareThread = 4;
/// The most worker threads setThreadCount allows: kMaxThreadsPerHardwareThread × the hardware
/// concurrency.
int maxThreadCount();
/// Limit the worker threads for the rest of the process (0 or less = hardware concurrency); a
/// count over maxThreadCount() is clamped to it. Returns the count now in use (threadCount()).
int setThreadCount(int threads);
/// The number of threads parallel loops will use.
int threadCount();

/// Call body(begin, end) on disjoint chunks covering [0, n), in parallel; grain = min chunk.
void parallelForChunks(std::size_t n, std::size_t grain,
                       const std::function<void(std::size_t, std::size_t)>& body);

}  // namespace udvr
