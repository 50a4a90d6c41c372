// The scans of `udvr build`'s input (build_passes.h): NaN/Inf and the data range, and the
// finite samples per voxel of --nan skip.
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <mutex>
#include <vector>

#include "udvr/stats/build_passes.h"
#include "udvr/util/check.h"
#include "udvr/util/parallel.h"

namespace udvr::detail {

double threadCpuSeconds() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

[[noreturn]] void failNonFinite(const InputScan& s, const Grid3& grid, bool ensemble) {
    const auto X = static_cast<std::size_t>(grid.dims[0]);
    const auto Y = static_cast<std::size_t>(grid.dims[1]);
    const std::size_t i = s.firstVoxel % X, j = (s.firstVoxel / X) % Y, k = s.firstVoxel / (X * Y);
    if (ensemble)
        UDVR_FAIL("the ensemble has " << s.nonFinite << " NaN/Inf samples (first at voxel (" << i
                                      << "," << j << "," << k << "), member " << s.firstMember
                                      << "); build needs finite values and never averages NaN "
                                         "(--nan skip: each voxel's finite members only)");
    UDVR_FAIL("the field has " << s.nonFinite << " NaN/Inf values (first at point (" << i << ","
                               << j << "," << k
                               << ")); build needs finite values and never averages NaN "
                                  "(--nan skip: each brick's finite values only)");
}

void scanMemberRows(InputScan& local, const float* rows, std::size_t count, int n,
                    std::size_t first, std::size_t b, std::size_t end) {
    for (int mIdx = 0; mIdx < n; ++mIdx) {
        const float* row = rows + static_cast<std::size_t>(mIdx) * count;
        for (std::size_t v = b; v < end; ++v) local.add(row[v], first + v, mIdx);
    }
}

void scanBrickPlanes(InputScan& local, const float* planes, const Grid3& f, int z0, int usedX,
                     int usedY, std::size_t p0, std::size_t p1) {
    const std::size_t plane = static_cast<std::size_t>(f.dims[0]) * f.dims[1];
    for (std::size_t zl = p0; zl < p1; ++zl)
        for (int y = 0; y < usedY; ++y) {
            const std::size_t row = zl * plane + static_cast<std::size_t>(y) * f.dims[0];
            const std::size_t global = f.index(0, y, z0 + static_cast<int>(zl));
            for (int x = 0; x < usedX; ++x)
                local.add(planes[row + static_cast<std::size_t>(x)],
                          global + static_cast<std::size_t>(x), -1);
        }
}

void finishScan(const InputScan& scan, const BuildOptions& opt, const Grid3& grid, bool ensemble,
                std::chrono::steady_clock::time_point start, double scanCpu, BuildReport* report) {
    if (scan.nonFinite > 0 && opt.nan == NanPolicy::Error) failNonFinite(scan, grid, ensemble);
    if (!report) return;
    *report = BuildReport{};
    report->seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    report->scanCpu = scanCpu;
}

FiniteCounts countFinite(std::size_t first, std::size_t count, int n, const GatherFn& gather) {
    FiniteCounts total;
    std::mutex mutex;
    const std::size_t un = static_cast<std::size_t>(n);
    parallelForChunks(count, kChunkVoxels, [&](std::size_t lb, std::size_t le) {
        const std::size_t b = first + lb, e = first + le;
        std::vector<float> buf(kChunkVoxels * un);
        FiniteCounts local;
        for (std::size_t c0 = b; c0 < e; c0 += kChunkVoxels) {
            const std::size_t c1 = std::min(e, c0 + kChunkVoxels);
            gather(c0, c1, buf.data());
            for (std::size_t v = c0; v < c1; ++v) {
                const float* s = buf.data() + (v - c0) * un;
                int finite = 0;
                for (std::size_t i = 0; i < un; ++i) finite += std::isfinite(s[i]) ? 1 : 0;
                local.fewest = std::min(local.fewest, finite);
                if (finite == n) continue;
                ++local.voxelsWith;
                local.nonFinite += static_cast<std::size_t>(n - finite);
                if (finite >= 2) continue;
                if (local.tooFew++ == 0) {  // voxels ascend within a task
                    local.firstTooFew = v;
                    local.firstTooFewCount = finite;
                }
            }
        }
        std::lock_guard<std::mutex> lock(mutex);
        total.merge(local);
    });
    return total;
}

void checkFiniteCounts(const FiniteCounts& total, const Grid3& grid, int n, bool bricks,
                       BuildReport* report) {
    if (total.tooFew > 0) {
        const auto X = static_cast<std::size_t>(grid.dims[0]);
        const auto Y = static_cast<std::size_t>(grid.dims[1]);
        const std::size_t v = total.firstTooFew;
        UDVR_FAIL("--nan skip needs at least 2 finite samples at every voxel: "
                  << (bricks ? "the brick of reduced voxel (" : "voxel (") << v % X << ","
                  << (v / X) % Y << "," << v / (X * Y) << ") has " << total.firstTooFewCount
                  << " of " << n << " (" << total.tooFew << " voxel"
                  << (total.tooFew == 1 ? " has" : "s have")
                  << " fewer than 2; give them finite values, e.g. a mask value)");
    }
    if (report) {
        report->nonFiniteSamples = total.nonFinite;
        report->voxelsWithNonFinite = total.voxelsWith;
        report->fewestFiniteSamples = total.fewest;
    }
}

}  // namespace udvr::detail
