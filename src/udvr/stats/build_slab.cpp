// The statistics of SPEC §2 over a slab of voxels (build_passes.h): moments, quantile
// boundaries and IQR by the build's estimator, the GMMs, and the model's field data.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <mutex>
#include <span>
#include <utility>
#include <vector>

#include "udvr/stats/build_passes.h"
#include "udvr/stats/gmm.h"
#include "udvr/stats/sort_runs.h"
#include "udvr/stats/voxel_stats.h"
#include "udvr/util/check.h"
#include "udvr/util/large_vector.h"
#include "udvr/util/parallel.h"
#include "udvr/util/progress.h"

namespace udvr::detail {
namespace {

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

}  // namespace

void buildSlab(const Grid3& grid, std::size_t first, std::size_t count, int n,
               const GatherFn& gather, const BuildOptions& opt, const InputScan& scan,
               double valueStep, ModelVolume& m, CoreTotals& t) {
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

}  // namespace udvr::detail
