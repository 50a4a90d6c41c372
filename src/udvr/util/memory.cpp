#include "udvr/util/memory.h"

#include <sys/resource.h>
#include <unistd.h>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

#include "udvr/util/check.h"

namespace udvr {
namespace {

/// The first number in a file ("max" and missing files: none).
bool readNumber(const char* path, double& out) {
    std::ifstream in(path);
    std::string word;
    if (!(in >> word)) return false;
    char* end = nullptr;
    out = std::strtod(word.c_str(), &end);
    return end != word.c_str() && *end == '\0' && std::isfinite(out);
}

/// This process's cgroup v2 directory under /sys/fs/cgroup ("" where unknown).
std::string cgroupDir() {
    std::ifstream in("/proc/self/cgroup");
    std::string line;
    while (std::getline(in, line))
        if (line.rfind("0::", 0) == 0) return "/sys/fs/cgroup" + line.substr(3);
    return "";
}

}  // namespace

std::size_t parseByteSize(const std::string& text, const std::string& what) {
    auto bad = [&]() -> std::size_t {
        UDVR_FAIL(what << " '" << text
                       << "' is not a size; expected bytes, or a number with K, M, G or T "
                          "(powers of 1024), e.g. 512M or 4G");
    };
    std::size_t i = 0;
    while (i < text.size() &&
           (std::isdigit(static_cast<unsigned char>(text[i])) != 0 || text[i] == '.'))
        ++i;
    if (i == 0) return bad();
    double value = 0.0;
    try {
        std::size_t used = 0;
        value = std::stod(text.substr(0, i), &used);
        if (used != i) return bad();
    } catch (const std::exception&) {
        return bad();
    }
    std::string unit = text.substr(i);
    if (!unit.empty() && unit.front() == ' ') unit.erase(0, 1);
    for (char& c : unit) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    double scale = 1.0;
    if (!unit.empty() && unit != "B") {
        const std::string letters = "KMGT";
        const std::size_t at = letters.find(unit[0]);
        const std::string rest = unit.substr(1);
        if (at == std::string::npos || !(rest.empty() || rest == "B" || rest == "IB")) return bad();
        scale = std::pow(1024.0, static_cast<double>(at + 1));
    }
    const double bytes = std::floor(value * scale);
    if (!(bytes >= 1.0))
        UDVR_FAIL(what << " '" << text << "' is no memory; expected a positive size, e.g. 4G");
    if (bytes > static_cast<double>(std::numeric_limits<std::size_t>::max() / 2))
        UDVR_FAIL(what << " '" << text << "' is too large");
    return static_cast<std::size_t>(bytes);
}

std::string byteSizeText(std::size_t bytes) {
    const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB"};
    double v = static_cast<double>(bytes);
    int u = 0;
    while (v >= 1024.0 && u < 4) {
        v /= 1024.0;
        ++u;
    }
    char buf[32];
    if (u == 0)
        std::snprintf(buf, sizeof buf, "%zu B", bytes);
    else
        std::snprintf(buf, sizeof buf,
                      v < 10.0    ? "%.2f %s"
                      : v < 100.0 ? "%.1f %s"
                                  : "%.0f %s",
                      v, units[u]);
    return buf;
}

MemoryHeadroom memoryHeadroom() {
    MemoryHeadroom h;
    auto consider = [&](double bytes, const std::string& source) {
        if (!(bytes >= 0.0)) bytes = 0.0;
        const auto b = static_cast<std::size_t>(
            std::min(bytes, static_cast<double>(std::numeric_limits<std::size_t>::max() / 2)));
        if (h.source.empty() || b < h.bytes) {
            h.bytes = b;
            h.source = source;
        }
    };
    {
        std::ifstream in("/proc/meminfo");
        std::string key;
        double kib = 0.0;
        std::string unit;
        while (in >> key >> kib) {
            std::getline(in, unit);
            if (key == "MemAvailable:") {
                consider(kib * 1024.0, "available memory");
                break;
            }
        }
    }
    if (h.source.empty()) {
        const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
        if (pages > 0 && page > 0)
            consider(static_cast<double>(pages) * static_cast<double>(page), "physical memory");
    }
    const std::string cg = cgroupDir();
    double max = 0.0, current = 0.0;
    if (!cg.empty() && readNumber((cg + "/memory.max").c_str(), max)) {
        if (!readNumber((cg + "/memory.current").c_str(), current)) current = 0.0;
        consider(max - current, "the cgroup's memory.max");
    }
    rlimit lim{};
    if (getrlimit(RLIMIT_AS, &lim) == 0 && lim.rlim_cur != RLIM_INFINITY) {
        double vm = 0.0;
        std::ifstream statm("/proc/self/statm");
        double pages = 0.0;
        if (statm >> pages) vm = pages * static_cast<double>(sysconf(_SC_PAGESIZE));
        consider(static_cast<double>(lim.rlim_cur) - vm, "the address-space limit (ulimit -v)");
    }
    return h;
}

std::size_t residentBytes() {
    std::ifstream statm("/proc/self/statm");
    double size = 0.0, resident = 0.0;
    if (!(statm >> size >> resident)) return 0;
    return static_cast<std::size_t>(resident * static_cast<double>(sysconf(_SC_PAGESIZE)));
}

}  // namespace udvr
