// `udvr build` in memory (build_model.h, SPEC §2): a model from an ensemble held whole, or
// from the K³ bricks of one field.
#include "udvr/stats/build_model.h"

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <vector>

#include "udvr/stats/build_passes.h"
#include "udvr/util/check.h"

namespace udvr {
namespace {

using detail::buildSlab;
using detail::checkFiniteCounts;
using detail::CoreTotals;
using detail::countFinite;
using detail::finishModel;
using detail::finishScan;
using detail::InputScan;
using detail::scanBrickPlanes;
using detail::scanMemberRows;
using detail::scanParallel;

/// The statistics of SPEC §2 for every voxel of `grid`, in memory (buildSlab over all voxels).
template <class Gather>
ModelVolume buildCore(const Grid3& grid, int n, const Gather& gather, const BuildOptions& opt,
                      const InputScan& scan, double valueStep, bool bricks, BuildReport* report) {
    const auto start = std::chrono::steady_clock::now();
    const bool skipNonFinite = opt.nan == NanPolicy::Skip && scan.nonFinite > 0;
    const std::size_t voxels = grid.pointCount();
    if (skipNonFinite)
        checkFiniteCounts(countFinite(0, voxels, n, gather), grid, n, bricks, report);
    CoreTotals totals;
    if (opt.density == DensityEstimate::Kde) totals.bandwidths.resize(voxels);
    ModelVolume m;
    buildSlab(grid, 0, voxels, n, gather, opt, scan, valueStep, m, totals);
    finishModel(m, n, voxels, opt, scan, valueStep, totals, report, start);
    return m;
}

}  // namespace

ModelVolume buildModel(const Ensemble& e, const BuildOptions& opt, BuildReport* report) {
    if (e.members < 2)
        UDVR_FAIL("the ensemble has " << e.members << " member(s); build needs at least 2");
    const std::size_t P = e.grid.pointCount();
    UDVR_CHECK(P > 0 && !e.voxelMajor &&
               e.values.size() == static_cast<std::size_t>(e.members) * P);
    validateBuildOptions(opt, e.members);
    checkDensityForInput(opt.density, e.valueStep, e.valueType);
    const auto start = std::chrono::steady_clock::now();

    // Non-finite check and data range, member rows scanned in voxel chunks.
    InputScan scan;
    const double scanCpu =
        scanParallel(P, 1 << 16, scan, [&](InputScan& local, std::size_t b, std::size_t end) {
            scanMemberRows(local, e.values.data(), P, e.members, 0, b, end);
        });
    finishScan(scan, opt, e.grid, true, start, scanCpu, report);

    const int n = e.members;
    // Transpose member-major rows into voxel-major sample runs: contiguous reads per member.
    auto gather = [&](std::size_t v0, std::size_t v1, float* buf) {
        for (int mIdx = 0; mIdx < n; ++mIdx) {
            const float* row = e.member(mIdx);
            for (std::size_t v = v0; v < v1; ++v)
                buf[(v - v0) * static_cast<std::size_t>(n) + static_cast<std::size_t>(mIdx)] =
                    row[v];
        }
    };
    ModelVolume m = buildCore(e.grid, n, gather, opt, scan, e.valueStep, false, report);
    m.setFullResolution(e.grid, 0);
    return m;
}

Grid3 downsampledGrid(const Grid3& full, int k) {
    if (k < 2) UDVR_FAIL("--downsample " << k << " is too small; expected a brick size K >= 2");
    for (int a = 0; a < 3; ++a)
        if (k > full.dims[a])
            UDVR_FAIL("--downsample " << k << " is larger than the grid (" << full.dims[0] << "x"
                                      << full.dims[1] << "x" << full.dims[2]
                                      << "); expected K <= every dimension");
    Grid3 g;
    for (int a = 0; a < 3; ++a) {
        g.dims[a] = full.dims[a] / k;
        g.spacing[a] = k * full.spacing[a];
        g.origin[a] = full.origin[a] + 0.5 * (k - 1) * full.spacing[a];  // brick centre
    }
    return g;
}

ModelVolume buildModelDownsampled(const ScalarField& f, int k, const BuildOptions& opt,
                                  BuildReport* report) {
    const Grid3 g = downsampledGrid(f.grid, k);
    UDVR_CHECK(f.values.size() == f.grid.pointCount());
    const int n = k * k * k;
    validateBuildOptions(opt, n);
    checkDensityForInput(opt.density, f.valueStep, f.valueType);
    const auto start = std::chrono::steady_clock::now();

    // Scan only the points inside whole bricks (the trailing planes are left out).
    const int usedX = g.dims[0] * k, usedY = g.dims[1] * k, usedZ = g.dims[2] * k;
    InputScan scan;
    const double scanCpu =
        scanParallel(static_cast<std::size_t>(usedZ), 1, scan,
                     [&](InputScan& local, std::size_t z0, std::size_t z1) {
                         scanBrickPlanes(local, f.values.data(), f.grid, 0, usedX, usedY, z0, z1);
                     });
    finishScan(scan, opt, f.grid, false, start, scanCpu, report);
    if (report)
        for (int a = 0; a < 3; ++a) report->droppedPlanes[a] = f.grid.dims[a] % k;

    const auto X = static_cast<std::size_t>(g.dims[0]);
    const auto Y = static_cast<std::size_t>(g.dims[1]);
    const auto uk = static_cast<std::size_t>(k);
    // A brick's samples: K rows of K contiguous values per z-plane, x fastest.
    auto gather = [&](std::size_t v0, std::size_t v1, float* buf) {
        for (std::size_t v = v0; v < v1; ++v) {
            const int i = static_cast<int>(v % X), j = static_cast<int>((v / X) % Y),
                      kz = static_cast<int>(v / (X * Y));
            float* dst = buf + (v - v0) * static_cast<std::size_t>(n);
            for (int c = 0; c < k; ++c)
                for (int b = 0; b < k; ++b) {
                    const float* src = f.values.data() + f.grid.index(i * k, j * k + b, kz * k + c);
                    std::copy(src, src + uk, dst);
                    dst += uk;
                }
        }
    };
    ModelVolume m = buildCore(g, n, gather, opt, scan, f.valueStep, true, report);
    m.setFullResolution(f.grid, k);
    return m;
}

}  // namespace udvr
