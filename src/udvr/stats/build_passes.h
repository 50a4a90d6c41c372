#pragma once
// The passes `udvr build` makes over its input (build_model.h; not part of the public API),
// shared by the in-memory builds (build_model.cpp) and the out-of-core ones
// (build_model_stream.cpp): the scan of NaN/Inf and of the data range, the finite counts of
// --nan skip (build_scan.cpp), and the statistics of SPEC §2 over a slab of voxels
// (build_slab.cpp).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <functional>
#include <limits>
#include <mutex>
#include <vector>

#include "udvr/stats/build_model.h"
#include "udvr/stats/model_volume.h"
#include "udvr/util/grid.h"
#include "udvr/util/parallel.h"

namespace udvr::detail {

/// This thread's CPU time in seconds (for the per-stage times of BuildReport).
double threadCpuSeconds();

// Voxels per gather buffer: 1024 voxels × 50 members of float = 200 KiB, inside L2; EM keeps
// its 16 lanes busy over a chunk, so larger chunks waste less at the end of one.
constexpr std::size_t kChunkVoxels = 1024;

/// gather(v0, v1, buf): voxel v's n samples to buf[(v − v0)·n …] for v in [v0, v1)
/// (buildSlab, countFinite).
using GatherFn = std::function<void(std::size_t, std::size_t, float*)>;

/// Non-finite samples and the range of the finite ones, over the samples a build will use.
struct InputScan {
    std::size_t nonFinite = 0;
    std::size_t firstVoxel = std::numeric_limits<std::size_t>::max();  // linear, input grid
    int firstMember = -1;                                              // ensemble only
    double min = std::numeric_limits<double>::infinity();
    double max = -std::numeric_limits<double>::infinity();

    void merge(const InputScan& o) {
        nonFinite += o.nonFinite;
        if (o.firstVoxel < firstVoxel) {
            firstVoxel = o.firstVoxel;
            firstMember = o.firstMember;
        }
        min = std::min(min, o.min);
        max = std::max(max, o.max);
    }
    void add(float v, std::size_t voxel, int member) {
        if (!std::isfinite(v)) {
            ++nonFinite;
            if (voxel < firstVoxel) {
                firstVoxel = voxel;
                firstMember = member;
            }
            return;
        }
        min = std::min(min, static_cast<double>(v));
        max = std::max(max, static_cast<double>(v));
    }
};

/// Throws the NaN/Inf error of a build: their count, the first voxel (i,j,k) and member.
[[noreturn]] void failNonFinite(const InputScan& s, const Grid3& grid, bool ensemble);

/// Scans [0, count) in chunks of at least `grain` on the threads: scanChunk(local, b, end) adds
/// to each thread's own InputScan, merged into `scan` at the end. Returns the threads' CPU
/// seconds.
template <class ScanChunk>
double scanParallel(std::size_t count, std::size_t grain, InputScan& scan,
                    const ScanChunk& scanChunk) {
    std::mutex mutex;
    double cpu = 0.0;
    parallelForChunks(count, grain, [&](std::size_t b, std::size_t end) {
        const double t0 = threadCpuSeconds();
        InputScan local;
        scanChunk(local, b, end);
        std::lock_guard<std::mutex> lock(mutex);
        scan.merge(local);
        cpu += threadCpuSeconds() - t0;
    });
    return cpu;
}

/// Adds voxels [b, end) of n member rows, member i's at rows + i·count, voxel v at linear index
/// first + v.
void scanMemberRows(InputScan& local, const float* rows, std::size_t count, int n,
                    std::size_t first, std::size_t b, std::size_t end);

/// Adds the samples inside whole bricks (x < usedX, y < usedY) of planes [p0, p1) of `planes`,
/// planes of the full grid `f` from its plane z0 on.
void scanBrickPlanes(InputScan& local, const float* planes, const Grid3& f, int z0, int usedX,
                     int usedY, std::size_t p0, std::size_t p1);

/// After an in-memory build's scan: fails on NaN/Inf under NanPolicy::Error, else starts the
/// report (wall seconds since `start`, the scan's CPU seconds).
void finishScan(const InputScan& scan, const BuildOptions& opt, const Grid3& grid, bool ensemble,
                std::chrono::steady_clock::time_point start, double scanCpu, BuildReport* report);

/// Finite samples per voxel (--nan skip), over one slab or the whole grid.
struct FiniteCounts {
    std::size_t voxelsWith = 0, tooFew = 0, nonFinite = 0;
    std::size_t firstTooFew = std::numeric_limits<std::size_t>::max();
    int firstTooFewCount = 0;
    int fewest = std::numeric_limits<int>::max();

    void merge(const FiniteCounts& o) {
        voxelsWith += o.voxelsWith;
        nonFinite += o.nonFinite;
        tooFew += o.tooFew;
        fewest = std::min(fewest, o.fewest);
        if (o.firstTooFew < firstTooFew) {
            firstTooFew = o.firstTooFew;
            firstTooFewCount = o.firstTooFewCount;
        }
    }
};

/// The finite samples of voxels [first, first + count) (gather as buildSlab's).
FiniteCounts countFinite(std::size_t first, std::size_t count, int n, const GatherFn& gather);

/// --nan skip: every voxel needs at least 2 finite samples (as the whole input needs 2 samples
/// per voxel: ddof = 1); otherwise the first voxel that has fewer is the error. Fills the
/// report's counts.
void checkFiniteCounts(const FiniteCounts& total, const Grid3& grid, int n, bool bricks,
                       BuildReport* report);

/// What buildSlab adds up over the slabs of one build.
struct CoreTotals {
    std::size_t constant = 0, notConverged = 0, fewerDistinct = 0, iterations = 0;
    double gatherCpu = 0.0, estimateCpu = 0.0, gmmCpu = 0.0;
    std::vector<float> bandwidths;  // kde: h per voxel of the whole grid, NaN for constant voxels
};

/// The statistics of SPEC §2 for voxels [first, first + count) of `grid` (all of them, or a
/// slab of whole z-planes in an out-of-core build), into m's arrays, which are sized for those
/// voxels (m.mean[v − first] …). gather(v0, v1, buf) writes voxel v's n samples to
/// buf[(v − v0)·n …] for v in [v0, v1), v1 − v0 ≤ kChunkVoxels, v the voxel's index in `grid`.
/// Every voxel's result depends on its own samples, the whole input's range (scan: the GMM's
/// σ floor) and its index (the GMM's random stream) only, so slabs give the whole build's
/// values bit for bit.
/// valueStep: the input's quantisation step (ScalarField::valueStep), used by dequantized only.
/// NanPolicy::Skip with non-finite samples in the input (scan.nonFinite > 0): each voxel's
/// samples are its finite ones (at least 2, checked before), its GMM fitted alone (fitGmm)
/// unless all n are finite.
void buildSlab(const Grid3& grid, std::size_t first, std::size_t count, int n,
               const GatherFn& gather, const BuildOptions& opt, const InputScan& scan,
               double valueStep, ModelVolume& m, CoreTotals& t);

/// The field data of a model built from n samples per voxel over `voxels` voxels (the arrays
/// are buildSlab's), and the report's totals.
void finishModel(ModelVolume& m, int n, std::size_t voxels, const BuildOptions& opt,
                 const InputScan& scan, double valueStep, CoreTotals& t, BuildReport* report,
                 std::chrono::steady_clock::time_point start);

}  // namespace udvr::detail
