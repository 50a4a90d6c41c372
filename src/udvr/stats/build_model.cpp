#include "udvr/stats/build_model.h"

#include <time.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <utility>
#include <vector>

#include "udvr/stats/sort_runs.h"
#include "udvr/util/check.h"
#include "udvr/util/choice.h"
#include "udvr/util/large_vector.h"
#include "udvr/util/parallel.h"
#include "udvr/util/progress.h"

namespace udvr {
namespace {

/// This thread's CPU time in seconds (for the per-stage times of BuildReport).
double threadCpuSeconds() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// Voxels per gather buffer: 1024 voxels × 50 members of float = 200 KiB, inside L2; EM keeps
// its 16 lanes busy over a chunk, so larger chunks waste less at the end of one.
constexpr std::size_t kChunkVoxels = 1024;

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
                    std::size_t first, std::size_t b, std::size_t end) {
    for (int mIdx = 0; mIdx < n; ++mIdx) {
        const float* row = rows + static_cast<std::size_t>(mIdx) * count;
        for (std::size_t v = b; v < end; ++v) local.add(row[v], first + v, mIdx);
    }
}

/// Adds the samples inside whole bricks (x < usedX, y < usedY) of planes [p0, p1) of `planes`,
/// planes of the full grid `f` from its plane z0 on.
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

/// After an in-memory build's scan: fails on NaN/Inf under NanPolicy::Error, else starts the
/// report (wall seconds since `start`, the scan's CPU seconds).
void finishScan(const InputScan& scan, const BuildOptions& opt, const Grid3& grid, bool ensemble,
                std::chrono::steady_clock::time_point start, double scanCpu, BuildReport* report) {
    if (scan.nonFinite > 0 && opt.nan == NanPolicy::Error) failNonFinite(scan, grid, ensemble);
    if (!report) return;
    *report = BuildReport{};
    report->seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    report->scanCpu = scanCpu;
}

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
template <class Gather>
FiniteCounts countFinite(std::size_t first, std::size_t count, int n, const Gather& gather) {
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

/// --nan skip: every voxel needs at least 2 finite samples (as the whole input needs 2 samples
/// per voxel: ddof = 1); otherwise the first voxel that has fewer is the error. Fills the
/// report's counts.
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

/// What buildSlab adds up over the slabs of one build.
struct CoreTotals {
    std::size_t constant = 0, notConverged = 0, fewerDistinct = 0, iterations = 0;
    double gatherCpu = 0.0, estimateCpu = 0.0, gmmCpu = 0.0;
    std::vector<float> bandwidths;  // kde: h per voxel of the whole grid, NaN for constant voxels
};

/// m's arrays sized for `voxels` voxels of `grid` with the options' q, levels and K (SPEC §7).
void sizeModelArrays(ModelVolume& m, const Grid3& grid, std::size_t voxels,
                     const BuildOptions& opt) {
    const int q = opt.quantiles, K = opt.gmmComponents;
    m.grid = grid;
    resizeLarge(m.mean, voxels);
    resizeLarge(m.stddev, voxels);
    resizeLarge(m.min, voxels);
    resizeLarge(m.max, voxels);
    resizeLarge(m.iqr, 2 * voxels);
    m.quantileCount = q;
    if (q > 0) resizeLarge(m.quantiles, voxels * static_cast<std::size_t>(q + 1));
    m.quantileLevels = normalizedQuantileLevels(opt.quantileLevels, q, "--quantile-levels");
    m.gmmComponents = K;
    if (K > 0) resizeLarge(m.gmm, voxels * static_cast<std::size_t>(3 * K));
}

/// One voxel's quantile boundaries b_0 … b_q (qv, null when q = 0) and IQR [b(¼), b(¾)] from
/// its sorted samples, by the build's estimator (SPEC §2): the dequantized mixture's exact
/// quantiles, a point mass for a constant voxel, numpy's linear sample quantiles, or the KDE's.
class VoxelQuantiles {
  public:
    VoxelQuantiles(const ModelVolume& m, const BuildOptions& opt, int n, double valueStep)
        : m_(m),
          opt_(opt),
          q_(opt.quantiles),
          kde_(opt.density == DensityEstimate::Kde),
          dequantized_(opt.density == DensityEstimate::Dequantized),
          valueStep_(valueStep),
          eps_(opt.tailEps > 0.0 ? opt.tailEps : 0.5 / static_cast<double>(n)),
          // b(0.25), b(0.75) among the boundaries (kde: the IQR is then read off them).
          quarter_(q_ > 0 ? m.boundaryAtLevel(0.25) : -1),
          threeQuarters_(q_ > 0 ? m.boundaryAtLevel(0.75) : -1),
          boundaryLevels_(static_cast<std::size_t>(q_ + 1)) {
        UDVR_CHECK(!dequantized_ || valueStep > 0.0);
        for (int j = 0; j <= q_; ++j)
            boundaryLevels_[static_cast<std::size_t>(j)] = m.quantileLevel(j);
    }
    /// Writes qv and iqr; returns the KDE bandwidth (NaN for a constant voxel, 0 without kde).
    /// `scratch` holds q + 1 doubles (dequantized only).
    float operator()(std::span<const float> sorted, const SampleMoments& mom, float* qv, float* iqr,
                     std::vector<double>& scratch) const {
        const bool constantVoxel = sorted.front() == sorted.back();
        if (dequantized_) {
            dequantizedBoundaries(sorted, qv, iqr, scratch);
            return 0.f;
        }
        if (constantVoxel) {
            // A point mass: every boundary is the common value (SPEC §2).
            if (qv) std::fill(qv, qv + q_ + 1, sorted[0]);
            iqr[0] = iqr[1] = sorted[0];
            return kde_ ? std::numeric_limits<float>::quiet_NaN() : 0.f;
        }
        if (!kde_) {
            // numpy's linear quantile at t_j; b_0 = min and b_q = max exactly.
            for (int j = 0; qv && j <= q_; ++j)
                qv[j] = static_cast<float>(empiricalQuantile(sorted, m_.quantileLevel(j)));
            iqr[0] = static_cast<float>(empiricalQuantile(sorted, 0.25));
            iqr[1] = static_cast<float>(empiricalQuantile(sorted, 0.75));
            return 0.f;
        }
        return kdeBoundaries(sorted, mom, qv, iqr);
    }

  private:
    // Every sample spread over its quantisation step, constant voxels too (a brick of v is
    // U[v − s/2, v + s/2]); the mixture's exact quantiles.
    void dequantizedBoundaries(std::span<const float> sorted, float* qv, float* iqr,
                               std::vector<double>& dq) const {
        if (qv) {
            dq.resize(static_cast<std::size_t>(q_ + 1));
            dequantizedQuantiles(sorted, valueStep_, boundaryLevels_, dq);
            for (int j = 0; j <= q_; ++j)
                qv[j] = static_cast<float>(dq[static_cast<std::size_t>(j)]);
        }
        std::array<double, 2> dqIqr{};
        dequantizedQuantiles(sorted, valueStep_, kIqrLevels, dqIqr);
        iqr[0] = static_cast<float>(dqIqr[0]);
        iqr[1] = static_cast<float>(dqIqr[1]);
    }
    // b_j = F⁻¹(t_j), tails at ε and 1 − ε; Newton from the sample quantile.
    float kdeBoundaries(std::span<const float> sorted, const SampleMoments& mom, float* qv,
                        float* iqr) const {
        const double h = kdeBandwidth(sorted, mom.stddev, opt_.bandwidth);
        auto inv = [&](double p) {
            return kdeQuantile(sorted, h, p, empiricalQuantile(sorted, p));
        };
        double prev = -std::numeric_limits<double>::infinity();
        for (int j = 0; qv && j <= q_; ++j) {
            const double p = j == 0 ? eps_ : j == q_ ? 1.0 - eps_ : m_.quantileLevel(j);
            prev = std::max(prev, inv(p));  // monotone despite solver tolerance
            qv[j] = static_cast<float>(prev);
        }
        if (qv && quarter_ > 0 && threeQuarters_ > 0) {
            iqr[0] = qv[quarter_];
            iqr[1] = qv[threeQuarters_];
        } else {
            iqr[0] = static_cast<float>(inv(0.25));
            iqr[1] = static_cast<float>(std::max(inv(0.75), static_cast<double>(iqr[0])));
        }
        return static_cast<float>(h);
    }

    static constexpr std::array<double, 2> kIqrLevels = {0.25, 0.75};
    const ModelVolume& m_;
    const BuildOptions& opt_;
    int q_;
    bool kde_, dequantized_;
    double valueStep_, eps_;
    int quarter_, threeQuarters_;
    std::vector<double> boundaryLevels_;
};

/// Counts of one thread's share of a build (CoreTotals' per-thread part).
struct ChunkCounts {
    std::size_t constant = 0, notConverged = 0, fewerDistinct = 0, iterations = 0;
    double gatherCpu = 0.0, estimateCpu = 0.0, gmmCpu = 0.0;
};

/// The GMMs of one chunk's voxels c0 … c0 + count − 1 (global indices; `base` the slab's
/// first) from their sorted samples buf (n per voxel; with `finite`, voxel i has finite[i]):
/// EM 16 voxels at a time (one per vector lane) where all n samples are finite, alone (same
/// random stream, bit for bit) otherwise. Voxel v's random stream is streamOffset + v.
void fitChunkGmms(const float* buf, std::size_t count, std::size_t un, const std::size_t* finite,
                  std::size_t c0, std::size_t base, std::uint64_t streamOffset, int K,
                  const GmmOptions& gmmOpt, ModelVolume& m, std::vector<GmmFitInfo>& infos,
                  GmmWorkspace& ws, ChunkCounts& counts) {
    const std::size_t stride = static_cast<std::size_t>(3 * K);
    // Voxels i0..i1 of the chunk, all with n samples.
    auto fitRun = [&](std::size_t i0, std::size_t i1) {
        fitGmmMany(std::span<const float>(buf + i0 * un, (i1 - i0) * un), un, gmmOpt,
                   streamOffset + c0 + i0,
                   std::span<float>(m.gmm.data() + (c0 - base + i0) * stride, (i1 - i0) * stride),
                   std::span<GmmFitInfo>(infos.data() + i0, i1 - i0), ws);
    };
    if (!finite) fitRun(0, count);
    for (std::size_t i = 0; finite && i < count;) {
        std::size_t j = i;
        while (j < count && finite[j] == un) ++j;
        if (j > i) {
            fitRun(i, j);
            i = j;
            continue;
        }
        // Fewer samples than n: alone, same stream (as in a batch, bit for bit).
        infos[i] =
            fitGmm(std::span<const float>(buf + i * un, finite[i]), gmmOpt, streamOffset + c0 + i,
                   std::span<float>(m.gmm.data() + (c0 - base + i) * stride, stride), ws);
        ++i;
    }
    for (std::size_t i = 0; i < count; ++i) {
        const GmmFitInfo& fi = infos[i];
        counts.iterations += static_cast<std::size_t>(fi.iterations);
        if (!fi.converged) ++counts.notConverged;
        const float* s = buf + i * un;
        const std::size_t ni = finite ? finite[i] : un;
        if (fi.distinctComponents < K && s[0] != s[ni - 1]) ++counts.fewerDistinct;
    }
}

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
template <class Gather>
void buildSlab(const Grid3& grid, std::size_t first, std::size_t count, int n, const Gather& gather,
               const BuildOptions& opt, const InputScan& scan, double valueStep, ModelVolume& m,
               CoreTotals& t) {
    const bool skipNonFinite = opt.nan == NanPolicy::Skip && scan.nonFinite > 0;
    const std::size_t un = static_cast<std::size_t>(n);
    const int q = opt.quantiles;
    const int K = opt.gmmComponents;
    const bool kde = opt.density == DensityEstimate::Kde;
    UDVR_CHECK(!kde || t.bandwidths.size() == grid.pointCount());
    sizeModelArrays(m, grid, count, opt);
    const VoxelQuantiles quantilesOf(m, opt, n, valueStep);

    GmmOptions gmmOpt;
    gmmOpt.components = std::max(K, 1);
    gmmOpt.seed = opt.gmmSeed;
    // σ floor 1e−3 of the data range (SPEC §2); an input that is constant everywhere uses 1e−3.
    const double range = opt.piece.wholeMax >= opt.piece.wholeMin
                             ? opt.piece.wholeMax - opt.piece.wholeMin
                             : scan.max - scan.min;
    gmmOpt.sigmaFloor = range > 0.0 ? 1e-3 * range : 1e-3;

    std::mutex totalsMutex;
    const std::size_t base = first;
    // Finite samples are sorted a chunk at a time, one voxel per vector lane (a sorting
    // network); with --nan skip each voxel's finite ones alone.
    const std::vector<std::pair<int, int>> network = sortingNetwork(n);
    parallelForChunks(count, kChunkVoxels, [&](std::size_t lb, std::size_t le) {
        const std::size_t b = base + lb, e = base + le;  // global voxels
        std::vector<float> buf(kChunkVoxels * un);       // sorted samples of a chunk, voxel-major
        std::vector<GmmFitInfo> infos(kChunkVoxels);
        std::vector<std::size_t> finite(skipNonFinite ? kChunkVoxels : 0);  // per voxel
        GmmWorkspace ws;
        std::vector<double> scratch;
        ChunkCounts c;
        for (std::size_t c0 = b; c0 < e; c0 += kChunkVoxels) {
            const std::size_t c1 = std::min(e, c0 + kChunkVoxels);
            const double t0 = threadCpuSeconds();
            gather(c0, c1, buf.data());
            const double t1 = threadCpuSeconds();
            c.gatherCpu += t1 - t0;
            if (!skipNonFinite) sortRuns(buf.data(), c1 - c0, un, network);
            for (std::size_t v = c0; v < c1; ++v) {
                float* s = buf.data() + (v - c0) * un;
                std::size_t nv = un;  // this voxel's samples
                if (skipNonFinite) {
                    nv = static_cast<std::size_t>(
                        std::remove_if(s, s + un, [](float x) { return !std::isfinite(x); }) - s);
                    finite[v - c0] = nv;
                    std::sort(s, s + nv);
                }
                const std::span<const float> sorted(s, nv);
                const SampleMoments mom = sampleMoments(sorted);
                m.mean[v - base] = static_cast<float>(mom.mean);
                m.stddev[v - base] = static_cast<float>(mom.stddev);
                m.min[v - base] = s[0];
                m.max[v - base] = s[nv - 1];
                if (s[0] == s[nv - 1]) ++c.constant;
                float* qv = q > 0
                                ? m.quantiles.data() + (v - base) * static_cast<std::size_t>(q + 1)
                                : nullptr;
                const float h =
                    quantilesOf(sorted, mom, qv, m.iqr.data() + 2 * (v - base), scratch);
                if (kde) t.bandwidths[v] = h;
            }
            const double t2 = threadCpuSeconds();
            c.estimateCpu += t2 - t1;
            if (K > 0) {
                fitChunkGmms(buf.data(), c1 - c0, un, skipNonFinite ? finite.data() : nullptr, c0,
                             base, opt.piece.firstVoxel, K, gmmOpt, m, infos, ws, c);
                c.gmmCpu += threadCpuSeconds() - t2;
            }
            if (opt.progress) opt.progress->advance(c1 - c0);
        }
        const std::lock_guard<std::mutex> lock(totalsMutex);
        t.constant += c.constant;
        t.notConverged += c.notConverged;
        t.fewerDistinct += c.fewerDistinct;
        t.iterations += c.iterations;
        t.gatherCpu += c.gatherCpu;
        t.estimateCpu += c.estimateCpu;
        t.gmmCpu += c.gmmCpu;
    });
}

/// The field data of a model built from n samples per voxel over `voxels` voxels (the arrays
/// are buildSlab's), and the report's totals.
void finishModel(ModelVolume& m, int n, std::size_t voxels, const BuildOptions& opt,
                 const InputScan& scan, double valueStep, CoreTotals& t, BuildReport* report,
                 std::chrono::steady_clock::time_point start) {
    const bool kde = opt.density == DensityEstimate::Kde;
    const bool dequantized = opt.density == DensityEstimate::Dequantized;
    const double eps = opt.tailEps > 0.0 ? opt.tailEps : 0.5 / static_cast<double>(n);
    m.quantileCount = opt.quantiles;
    m.quantileLevels =
        normalizedQuantileLevels(opt.quantileLevels, opt.quantiles, "--quantile-levels");
    m.gmmComponents = opt.gmmComponents;
    std::vector<float>& bandwidths = t.bandwidths;
    m.density = densityEstimateName(opt.density);
    m.bandwidthRule = kde ? opt.bandwidthText : "";
    m.tailEps = kde ? eps : 0.0;
    m.bandwidth = dequantized ? valueStep : 0.0;  // dequantized: the uniform kernel's width s
    if (kde && opt.bandwidth.rule == BandwidthRule::Fixed) {
        m.bandwidth = opt.bandwidth.fixed;
    } else if (kde) {
        // Median h over the voxels that have one (constant voxels have none).
        auto last = std::remove_if(bandwidths.begin(), bandwidths.end(),
                                   [](float h) { return std::isnan(h); });
        const auto count = static_cast<std::size_t>(last - bandwidths.begin());
        if (count > 0) {
            auto mid = bandwidths.begin() + static_cast<std::ptrdiff_t>(count / 2);
            std::nth_element(bandwidths.begin(), mid, last);
            double med = *mid;
            if (count % 2 == 0) med = 0.5 * (med + *std::max_element(bandwidths.begin(), mid));
            m.bandwidth = med;
        }
    }
    m.samplesPerVoxel = n;
    m.source = opt.source;

    if (report) {
        report->voxels = voxels;
        report->samplesPerVoxel = n;
        report->constantVoxels = t.constant;
        report->gmmNotConverged = t.notConverged;
        report->gmmFewerDistinct = t.fewerDistinct;
        const std::size_t fitted = voxels - t.constant;
        report->meanGmmIterations =
            fitted > 0 ? static_cast<double>(t.iterations) / static_cast<double>(fitted) : 0.0;
        report->dataMin = scan.min;
        report->dataMax = scan.max;
        report->gatherCpu = t.gatherCpu;
        report->estimateCpu = t.estimateCpu;
        report->gmmCpu = t.gmmCpu;
        report->seconds +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
}

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

void validateBuildOptions(const BuildOptions& o, int n) {
    if (n < 2) UDVR_FAIL("build needs at least 2 samples per voxel, the input gives " << n);
    if (o.quantiles < 0 || o.quantiles > 1024)
        UDVR_FAIL("--quantiles " << o.quantiles
                                 << " is out of range; expected 1..1024 (or 0 to skip quantiles)");
    normalizedQuantileLevels(o.quantileLevels, o.quantiles, "--quantile-levels");
    if (o.gmmComponents < 0 || o.gmmComponents > kMaxGmmComponents)
        UDVR_FAIL("--gmm " << o.gmmComponents << " is out of range; expected 1.."
                           << kMaxGmmComponents << " components (or 0 to skip the GMM)");
    if (o.gmmComponents > n)
        UDVR_FAIL("--gmm " << o.gmmComponents << " needs at least " << o.gmmComponents
                           << " samples per voxel, the input has " << n << "; use --gmm " << n
                           << " or fewer");
    if (o.density == DensityEstimate::Kde) {
        if (o.bandwidth.rule == BandwidthRule::Fixed &&
            !(std::isfinite(o.bandwidth.fixed) && o.bandwidth.fixed > 0.0))
            UDVR_FAIL("--bandwidth " << o.bandwidth.fixed << " is not a positive finite number");
        if (o.tailEps != 0.0) {
            if (!(o.tailEps > 0.0 && o.tailEps < 0.5))
                UDVR_FAIL("--tail-eps " << o.tailEps << " is out of range; expected 0 < E < 0.5");
            // The tails must stay inside the outer quantiles: ε ≤ t_1 and 1 − ε ≥ t_{q−1}.
            const double outer =
                o.quantileLevels.size() > 2
                    ? std::min(o.quantileLevels[1], 1.0 - o.quantileLevels[o.quantiles - 1])
                    : 1.0 / o.quantiles;
            if (o.quantiles > 0 && o.tailEps > outer)
                UDVR_FAIL("--tail-eps "
                          << o.tailEps << " exceeds "
                          << (o.quantileLevels.size() > 2 ? "the outer quantiles' mass " : "1/q = ")
                          << outer << "; the tail boundaries would cross b_1");
        }
    } else if (o.tailEps != 0.0) {
        UDVR_FAIL("--tail-eps applies to --density kde only");
    }
}

NanPolicy parseNanPolicy(const std::string& name) {
    constexpr std::pair<std::string_view, NanPolicy> kNames[] = {{"error", NanPolicy::Error},
                                                                 {"skip", NanPolicy::Skip}};
    return parseChoice(name, kNames, "--nan");
}

DensityEstimate defaultDensity(bool bricks) {
    return bricks ? DensityEstimate::Kde : DensityEstimate::Empirical;
}

void checkDensityForInput(DensityEstimate density, double valueStep, const std::string& valueType) {
    if (density != DensityEstimate::Dequantized || valueStep > 0.0) return;
    UDVR_FAIL(
        "--density dequantized spreads each value over its quantisation step and needs an "
        "integer-typed input; this input holds "
        << (valueType.empty() ? std::string("floating-point") : valueType)
        << " values: use --density empirical or kde");
}

BuildFitNotes fitBuildOptionsToSamples(BuildOptions& opt, long long samples, bool gmmGiven,
                                       bool quantilesGiven) {
    const int n = static_cast<int>(std::min<long long>(samples, 1 << 30));
    BuildFitNotes notes;
    std::string& info = notes.info;
    if (n >= 2 && opt.gmmComponents > n && opt.gmmComponents <= kMaxGmmComponents) {
        if (gmmGiven)
            notes.warnings.push_back("--gmm " + std::to_string(opt.gmmComponents) +
                                     " needs at least " + std::to_string(opt.gmmComponents) +
                                     " samples per voxel, the input has " + std::to_string(n) +
                                     ": GMM K lowered from " + std::to_string(opt.gmmComponents) +
                                     " to " + std::to_string(n));
        else
            info += "GMM K lowered from " + std::to_string(opt.gmmComponents) + " to " +
                    std::to_string(n);
        opt.gmmComponents = n;
    }
    if (n >= 2 && opt.density == DensityEstimate::Empirical && opt.quantiles > n) {
        const std::string text = "the " + std::to_string(opt.quantiles + 1) +
                                 " quantile boundaries interpolate between only " +
                                 std::to_string(n) + " sample values";
        if (quantilesGiven)
            notes.warnings.push_back("--quantiles " + std::to_string(opt.quantiles) + " with " +
                                     std::to_string(n) + " samples per voxel: " + text);
        else
            info += (info.empty() ? "" : "; ") + text;
    }
    validateBuildOptions(opt, n);
    return notes;
}

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

// ---- out of core ---------------------------------------------------------------------------

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

using GatherFn = std::function<void(std::size_t, std::size_t, float*)>;

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
