// `udvr build` out of core (build_model.h, issue 15): the input read a slab of z-planes at a
// time, the model handed on a slab at a time, and what such a build holds in memory.
#include <algorithm>
#include <chrono>
#include <cstddef>
#include <functional>
#include <limits>
#include <span>
#include <vector>

#include "udvr/stats/build_model.h"
#include "udvr/stats/build_passes.h"
#include "udvr/util/check.h"
#include "udvr/util/large_vector.h"
#include "udvr/util/parallel.h"
#include "udvr/util/progress.h"

namespace udvr {

using detail::buildSlab;
using detail::checkFiniteCounts;
using detail::CoreTotals;
using detail::countFinite;
using detail::failNonFinite;
using detail::finishModel;
using detail::FiniteCounts;
using detail::GatherFn;
using detail::InputScan;
using detail::kChunkVoxels;
using detail::scanBrickPlanes;
using detail::scanMemberRows;
using detail::scanParallel;
using detail::threadCpuSeconds;

std::size_t modelBytesPerVoxel(const BuildOptions& o) {
    const std::size_t q = o.quantiles > 0 ? static_cast<std::size_t>(o.quantiles) + 1 : 0;
    return sizeof(float) * (4 + 2 + q + 3 * static_cast<std::size_t>(o.gmmComponents));
}

BuildMemory buildMemory(const Grid3& input, int members, int k, const BuildOptions& options,
                        std::size_t readerScratchPerPlane, std::size_t readerScratchFixed) {
    const std::size_t X = static_cast<std::size_t>(input.dims[0]);
    const std::size_t Y = static_cast<std::size_t>(input.dims[1]);
    const auto uk = static_cast<std::size_t>(std::max(k, 1));
    const std::size_t modelPlane = k > 1 ? (X / uk) * (Y / uk) : X * Y;
    const std::size_t modelVoxels =
        modelPlane * (k > 1 ? static_cast<std::size_t>(input.dims[2]) / uk
                            : static_cast<std::size_t>(input.dims[2]));
    const std::size_t n = k > 1 ? uk * uk * uk : static_cast<std::size_t>(members);
    BuildMemory b;
    b.perPlane =
        uk * (static_cast<std::size_t>(members) * X * Y * sizeof(float) + readerScratchPerPlane) +
        modelPlane * modelBytesPerVoxel(options);
    const std::size_t threads = static_cast<std::size_t>(std::max(threadCount(), 1));
    b.fixed = (options.density == DensityEstimate::Kde ? modelVoxels * sizeof(float) : 0) +
              threads * kChunkVoxels * n * sizeof(float) * 2 + readerScratchFixed +
              (std::size_t{8} << 20);  // the writer: a block per array, a copy buffer
    return b;
}

namespace {

double secondsSince(std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

/// The passes of an out-of-core build over slabs of `slabPlanes` model z-planes (k input planes
/// each): the scan, the finite counts (--nan skip with NaN/Inf only), the statistics.
/// scanSlab(buf, mz0, mz1, scan) scans the samples of model planes [mz0, mz1) held in buf (the
/// input planes [k·mz0, k·mz1) as SlabRead fills them); gatherFor(buf, mz0, mz1) gives the
/// gather of those voxels, by their index in the model grid.
ModelVolume streamBuild(
    const SlabInput& in, const Grid3& grid, int k, int slabPlanes, int n, bool bricks,
    const BuildOptions& options, const SlabSink& sink, const SlabProgress& progress,
    BuildReport* report,
    const std::function<void(std::span<const float>, int, int, InputScan&)>& scanSlab,
    const std::function<GatherFn(std::span<const float>, int, int)>& gatherFor) {
    const auto start = std::chrono::steady_clock::now();
    const int Z = grid.dims[2];
    UDVR_CHECK(slabPlanes >= 1 && in.read);
    slabPlanes = std::min(slabPlanes, Z);
    const int slabs = (Z + slabPlanes - 1) / slabPlanes;
    // The planes this build computes (BuildOptions::modelPlanes); the scans cover all Z.
    const int zBegin = options.modelPlanes.begin;
    const int zEnd = options.modelPlanes.end < 0 ? Z : options.modelPlanes.end;
    UDVR_CHECK(0 <= zBegin && zBegin < zEnd && zEnd <= Z);
    const bool allPlanes = zBegin == 0 && zEnd == Z;
    const int buildSlabs = (zEnd - zBegin + slabPlanes - 1) / slabPlanes;
    const std::size_t inPlane =
        static_cast<std::size_t>(in.grid.dims[0]) * static_cast<std::size_t>(in.grid.dims[1]);
    const std::size_t modelPlane =
        static_cast<std::size_t>(grid.dims[0]) * static_cast<std::size_t>(grid.dims[1]);
    const std::size_t voxels = grid.pointCount();
    std::vector<float> buf;  // one slab of the input, member-major
    double readSeconds = 0.0;
    struct Slab {
        int mz0, mz1;
        std::size_t first, count;  // model voxels
    };
    auto slabFrom = [&](int z0, int z1) {
        Slab sl;
        sl.mz0 = z0;
        sl.mz1 = z1;
        sl.first = static_cast<std::size_t>(sl.mz0) * modelPlane;
        sl.count = static_cast<std::size_t>(sl.mz1 - sl.mz0) * modelPlane;
        return sl;
    };
    auto slabAt = [&](int s) {
        return slabFrom(s * slabPlanes, std::min(Z, (s + 1) * slabPlanes));
    };
    // Slab s of the statistics pass: within [zBegin, zEnd).
    auto buildSlabAt = [&](int s) {
        return slabFrom(zBegin + s * slabPlanes, std::min(zEnd, zBegin + (s + 1) * slabPlanes));
    };
    const std::size_t builtVoxels = static_cast<std::size_t>(zEnd - zBegin) * modelPlane;
    auto read = [&](const Slab& sl) {
        const auto t0 = std::chrono::steady_clock::now();
        const std::size_t size = static_cast<std::size_t>(in.members) *
                                 static_cast<std::size_t>((sl.mz1 - sl.mz0) * k) * inPlane;
        if (buf.empty()) resizeLarge(buf, size);  // the first slab is the largest
        in.read(sl.mz0 * k, sl.mz1 * k, std::span<float>(buf.data(), size));
        readSeconds += secondsSince(t0);
        return std::span<const float>(buf.data(), size);
    };
    auto barFor = [&](const char* pass, int s, const Slab& sl, int of) -> ProgressBar* {
        return progress ? progress(pass, s, of, sl.count) : nullptr;
    };

    InputScan scan;
    double scanCpu = 0.0;
    auto scanOne = [&](const Slab& sl, std::span<const float> data) {
        const double t0 = threadCpuSeconds();
        scanSlab(data, sl.mz0, sl.mz1, scan);
        scanCpu += threadCpuSeconds() - t0;
    };
    // A statistics pass over slabs 0 … count − 1 (slabOf): each built and handed to the sink;
    // with scanFirst each is scanned first (the one-pass build: a slab with NaN/Inf ends it once
    // the rest is scanned, for the count). The model's header over `built` voxels.
    auto buildPass = [&](int count, const auto& slabOf, const char* pass, bool scanFirst,
                         std::size_t built) {
        CoreTotals totals;
        // NaN: no bandwidth (constant voxels, and those of other ranks), left out of the median.
        if (options.density == DensityEstimate::Kde)
            totals.bandwidths.resize(voxels, std::numeric_limits<float>::quiet_NaN());
        BuildOptions opt = options;
        ModelVolume slabModel;
        for (int s = 0; s < count; ++s) {
            const Slab sl = slabOf(s);
            opt.progress = barFor(pass, s, sl, count);
            const std::span<const float> data = read(sl);
            if (scanFirst) {
                scanOne(sl, data);
                if (scan.nonFinite > 0) {
                    for (int r = s + 1; r < count; ++r) scanOne(slabOf(r), read(slabOf(r)));
                    failNonFinite(scan, in.grid, !bricks);
                }
            }
            buildSlab(grid, sl.first, sl.count, n, gatherFor(data, sl.mz0, sl.mz1), opt, scan,
                      in.valueStep, slabModel, totals);
            sink(slabModel, sl.first);
        }
        ModelVolume m;
        m.grid = grid;
        finishModel(m, n, built, options, scan, in.valueStep, totals, report, start);
        if (report) {
            report->readSeconds = readSeconds;
            report->seconds -= readSeconds;
        }
        return m;
    };
    if (options.gmmComponents == 0 && options.nan == NanPolicy::Error && allPlanes) {
        // One pass: without a GMM nothing needs the whole input's range, and NaN/Inf are an
        // error.
        if (report) *report = BuildReport{};
        ModelVolume m = buildPass(slabs, slabAt, "scan+build", true, voxels);
        if (report) {
            report->scanCpu = scanCpu;
            report->slabs = slabs;
            report->inputPasses = 1;
        }
        return m;
    }

    // Pass 1: non-finite samples and the range, over the whole input.
    for (int s = 0; s < slabs; ++s) {
        const Slab sl = slabAt(s);
        ProgressBar* bar = barFor("scan", s, sl, slabs);
        scanOne(sl, read(sl));
        if (bar) bar->advance(sl.count);
    }
    if (scan.nonFinite > 0 && options.nan == NanPolicy::Error)
        failNonFinite(scan, in.grid, !bricks);
    if (report) {
        *report = BuildReport{};
        report->scanCpu = scanCpu;
        report->slabs = slabs;
        report->inputPasses = 2;
    }
    if (options.nan == NanPolicy::Skip && scan.nonFinite > 0) {
        if (report) report->inputPasses = 3;
        FiniteCounts counts;
        for (int s = 0; s < slabs; ++s) {
            const Slab sl = slabAt(s);
            ProgressBar* bar = barFor("count", s, sl, slabs);
            const std::span<const float> data = read(sl);
            counts.merge(countFinite(sl.first, sl.count, n, gatherFor(data, sl.mz0, sl.mz1)));
            if (bar) bar->advance(sl.count);
        }
        checkFiniteCounts(counts, grid, n, bricks, report);
    }

    // Pass 2: the statistics, slab by slab, each handed to the sink.
    return buildPass(buildSlabs, buildSlabAt, "build", false, builtVoxels);
}

}  // namespace

ModelVolume buildModelStreamed(const SlabInput& in, int slabPlanes, const BuildOptions& opt,
                               const SlabSink& sink, const SlabProgress& progress,
                               BuildReport* report) {
    if (in.members < 2)
        UDVR_FAIL("the ensemble has " << in.members << " member(s); build needs at least 2");
    UDVR_CHECK(in.grid.pointCount() > 0);
    validateBuildOptions(opt, in.members);
    checkDensityForInput(opt.density, in.valueStep, in.valueType);
    const int n = in.members;
    const std::size_t plane =
        static_cast<std::size_t>(in.grid.dims[0]) * static_cast<std::size_t>(in.grid.dims[1]);
    auto scanSlab = [&](std::span<const float> data, int z0, int z1, InputScan& scan) {
        const std::size_t first = static_cast<std::size_t>(z0) * plane;
        const std::size_t count = static_cast<std::size_t>(z1 - z0) * plane;
        scanParallel(count, 1 << 16, scan, [&](InputScan& local, std::size_t b, std::size_t end) {
            scanMemberRows(local, data.data(), count, n, first, b, end);
        });
    };
    auto gatherFor = [&](std::span<const float> data, int z0, int z1) -> GatherFn {
        const std::size_t first = static_cast<std::size_t>(z0) * plane;
        const std::size_t count = static_cast<std::size_t>(z1 - z0) * plane;
        const float* base = data.data();
        return [=](std::size_t v0, std::size_t v1, float* buf) {
            for (int mIdx = 0; mIdx < n; ++mIdx) {
                const float* row = base + static_cast<std::size_t>(mIdx) * count - first;
                for (std::size_t v = v0; v < v1; ++v)
                    buf[(v - v0) * static_cast<std::size_t>(n) + static_cast<std::size_t>(mIdx)] =
                        row[v];
            }
        };
    };
    ModelVolume m = streamBuild(in, in.grid, 1, slabPlanes, n, false, opt, sink, progress, report,
                                scanSlab, gatherFor);
    m.setFullResolution(in.grid, 0);
    return m;
}

ModelVolume buildModelDownsampledStreamed(const SlabInput& in, int k, int slabBricks,
                                          const BuildOptions& opt, const SlabSink& sink,
                                          const SlabProgress& progress, BuildReport* report) {
    const Grid3& f = in.grid;
    const Grid3 g = downsampledGrid(f, k);
    UDVR_CHECK(in.members == 1);
    const int n = k * k * k;
    validateBuildOptions(opt, n);
    checkDensityForInput(opt.density, in.valueStep, in.valueType);
    const int usedX = g.dims[0] * k, usedY = g.dims[1] * k;
    const auto Xin = static_cast<std::size_t>(f.dims[0]);
    const auto Yin = static_cast<std::size_t>(f.dims[1]);
    const std::size_t inPlane = Xin * Yin;
    auto scanSlab = [&](std::span<const float> data, int mz0, int mz1, InputScan& scan) {
        scanParallel(static_cast<std::size_t>(mz1 - mz0) * k, 1, scan,
                     [&](InputScan& local, std::size_t p0, std::size_t p1) {
                         scanBrickPlanes(local, data.data(), f, mz0 * k, usedX, usedY, p0, p1);
                     });
    };
    const auto X = static_cast<std::size_t>(g.dims[0]);
    const auto Y = static_cast<std::size_t>(g.dims[1]);
    const auto uk = static_cast<std::size_t>(k);
    auto gatherFor = [&](std::span<const float> data, int mz0, int) -> GatherFn {
        const float* base = data.data();
        return [=](std::size_t v0, std::size_t v1, float* buf) {
            for (std::size_t v = v0; v < v1; ++v) {
                const std::size_t i = v % X, j = (v / X) % Y, kz = v / (X * Y);
                float* dst = buf + (v - v0) * static_cast<std::size_t>(n);
                for (std::size_t c = 0; c < uk; ++c)
                    for (std::size_t b = 0; b < uk; ++b) {
                        const std::size_t zl = (kz - static_cast<std::size_t>(mz0)) * uk + c;
                        const float* src = base + zl * inPlane + (j * uk + b) * Xin + i * uk;
                        std::copy(src, src + uk, dst);
                        dst += uk;
                    }
            }
        };
    };
    ModelVolume m = streamBuild(in, g, k, slabBricks, n, true, opt, sink, progress, report,
                                scanSlab, gatherFor);
    if (report)
        for (int a = 0; a < 3; ++a) report->droppedPlanes[a] = f.dims[a] % k;
    m.setFullResolution(f, k);
    return m;
}

}  // namespace udvr
