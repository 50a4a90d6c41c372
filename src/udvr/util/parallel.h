#pragma once
// Parallel loops over index ranges, backed by oneTBB. The thread count is global and set
// once by the front end (--threads); 0 means all cores.
#include <cstddef>
#include <functional>

namespace udvr {

/// Limit the worker threads for the rest of the process (0 = hardware concurrency).
void setThreadCount(int threads);
/// The number of threads parallel loops will use.
int threadCount();

/// Call body(begin, end) on disjoint chunks covering [0, n), in parallel; grain = min chunk.
void parallelForChunks(std::size_t n, std::size_t grain,
                       const std::function<void(std::size_t, std::size_t)>& body);

}  // namespace udvr
