#pragma once
// Memory sizes for `build --memory-limit` (the out-of-core build): parsing "4G", and how much
// this process may use (available memory, a cgroup's limit, an address-space rlimit).
#include <cstddef>
#include <string>

namespace udvr {

/// Bytes from "123456", "512M", "4G", "1.5GiB", "2T" (K, M, G, T: powers of 1024; an optional
/// "B" or "iB" after the letter). Throws UdvrError naming `what` otherwise (also for 0).
std::size_t parseByteSize(const std::string& text, const std::string& what);

/// "1.5 GiB", "512 MiB", "10 KiB", "100 B".
std::string byteSizeText(std::size_t bytes);

/// What this process may still allocate: the least of MemAvailable (/proc/meminfo), a cgroup
/// v2 limit minus its current use (memory.max − memory.current), and RLIMIT_AS minus the
/// address space in use. `source` says which one was the least; 0 bytes when none is known.
struct MemoryHeadroom {
    std::size_t bytes = 0;
    std::string source;
};
MemoryHeadroom memoryHeadroom();

/// This process's resident set size now (/proc/self/statm), 0 where unknown.
std::size_t residentBytes();

}  // namespace udvr
