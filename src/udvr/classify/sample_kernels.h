#pragma once
// Per-sample classification kernels: reconstruct (SPEC §3) and classify (SPEC §4) at an
// index-space point. The renderer is templated on the kernel type so the per-sample work inlines
// into the ray loop; withKernel() does the one switch per frame.
//
// Every kernel type K provides
//   UDVR_CPU_GPU Rgba classifyAt(float x, float y, float z) const;
//       index-space point (clamped into the grid); returns (E[α·r], E[α·g], E[α·b], E[α]),
//       before opacity correction.
//   UDVR_CPU_GPU void voxelSupport(std::size_t voxel, float& lo, float& hi) const;
//       a value interval outside which the voxel's distribution has no (or negligible) mass;
//       used to build empty-space-skipping tables. For every model the distribution at a point
//       of a cell lies inside the hull of its 8 corners' supports (supports interpolate
//       linearly: Σ w(μ ± kσ) ⊇ μ(p) ± kσ(p) since sqrt(Σw²σ²) ≤ Σwσ), so a cell whose hull
//       has α = 0 can be skipped.
// Kernels are plain structs of sizes and raw pointers into storage that outlives them (a
// ModelVolume and a TfTableStorage owned by withKernel), so the same code can later be compiled
// for CUDA.
#include <cmath>
#include <cstddef>
#include <utility>

#include "udvr/classify/expected_tf.h"
#include "udvr/classify/model_kind.h"
#include "udvr/classify/tf_table.h"
#include "udvr/classify/transfer_function.h"
#include "udvr/reconstruct/box_spline.h"
#include "udvr/reconstruct/gaussian_interp.h"
#include "udvr/reconstruct/gmm_ordered.h"
#include "udvr/reconstruct/quantile_interp.h"
#include "udvr/reconstruct/trilinear.h"
#include "udvr/stats/model_volume.h"

namespace udvr {

/// Gaussian supports for skipping are μ ± kSupportSigmas·σ (mass outside: 2·Φ(−6) ≈ 2e−9).
inline constexpr double kSupportSigmas = 6.0;
/// Uniform widths ≤ this × data range are folded into the shift (SPEC §3 uniform).
inline constexpr double kUniformTinyWidth = 1e-9;
/// Quantile widths ≤ this × data range are zero widths for quantile-mean (SPEC §4).
inline constexpr double kQuantileZeroWidth = 1e-12;

namespace detail {
UDVR_CPU_GPU inline Rgba toRgba(const double v[4]) {
    return Rgba{static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2]),
                static_cast<float>(v[3])};
}

/// b_j(p) = Σ_c w_c b_{j,c} for the N boundaries j = j0 … j0+N−1 into out[0 … N−1]:
/// corner-major, so the inner loop runs over a voxel's contiguous boundaries (vectorised, N a
/// compile-time constant). Per j the sum runs over the corners in the same order and arithmetic
/// as interpolateBoundary, so the values are identical.
template <int N>
UDVR_CPU_GPU inline void interpolateBoundaryRun(const TrilinearCell& cell, const float* data,
                                                std::size_t stride, int j0, double (&out)[N]) {
    for (int j = 0; j < N; ++j) out[j] = 0.0;
    for (int c = 0; c < 8; ++c) {
        const double w = static_cast<double>(cell.weight[c]);
        const float* b = data + cell.corner[c] * stride + static_cast<std::size_t>(j0);
        for (int j = 0; j < N; ++j) out[j] += w * static_cast<double>(b[j]);
    }
}

/// pieceOf(x) for a non-decreasing sequence of x, walking up from the previous piece k (exact:
/// the same piece as TfTable::pieceOf; NaN or a decrease falls back to it).
UDVR_CPU_GPU inline int nextPiece(const TfTable& tf, int k, double xPrev, double x) {
    if (!(x >= xPrev)) return tf.pieceOf(x);
    while (k < tf.breakCount && x >= tf.breaks[k]) ++k;
    return k;
}
}  // namespace detail

/// Mean field: TF(Σ w_c μ_c), exact TF evaluation through the piece table (O(1)).
struct MeanKernel {
    int dims[3];
    const float* mean;
    TfTable tf;

    UDVR_CPU_GPU Rgba classifyAt(float x, float y, float z) const {
        const TrilinearCell cell = trilinearCell(dims, x, y, z);
        double v[4];
        tf.eval(interpolateMean(cell, mean), v);
        return detail::toRgba(v);
    }
    UDVR_CPU_GPU void voxelSupport(std::size_t voxel, float& lo, float& hi) const {
        lo = hi = mean[voxel];
    }
};

/// Uniform: X = Σ w_c U[lo_c, hi_c] (box spline), exact expectation. lo/hi = μ ∓ √3σ
/// (variance-matched, `first` = mean, `second` = stddev) or [min, max] (`minMax`).
struct UniformKernel {
    int dims[3];
    const float* first;
    const float* second;
    bool minMax;
    double tinyWidth;  // data units; widths at or below go into the shift
    TfTable tf;

    UDVR_CPU_GPU void interval(std::size_t voxel, double& lo, double& hi) const {
        if (minMax) {
            lo = first[voxel];
            hi = second[voxel];
        } else {
            const double h = 1.7320508075688772 * static_cast<double>(second[voxel]);
            lo = static_cast<double>(first[voxel]) - h;
            hi = static_cast<double>(first[voxel]) + h;
        }
    }
    UDVR_CPU_GPU UniformSum sumAt(const TrilinearCell& cell) const {
        double lo[8], hi[8];
        for (int c = 0; c < 8; ++c) interval(cell.corner[c], lo[c], hi[c]);
        return makeUniformSum(lo, hi, cell.weight, tinyWidth);
    }
    UDVR_CPU_GPU Rgba classifyAt(float x, float y, float z) const {
        double v[4];
        expectedTfUniformSum(tf, sumAt(trilinearCell(dims, x, y, z)), v);
        return detail::toRgba(v);
    }
    UDVR_CPU_GPU void voxelSupport(std::size_t voxel, float& lo, float& hi) const {
        double l, h;
        interval(voxel, l, h);
        lo = static_cast<float>(l);
        hi = static_cast<float>(h);
    }
};

/// Gaussian: N(Σ w μ, Σ w² σ²), exact expectation (erf terms per TF piece).
struct GaussianKernel {
    int dims[3];
    const float* mean;
    const float* stddev;
    TfTable tf;

    UDVR_CPU_GPU Rgba classifyAt(float x, float y, float z) const {
        const GaussianParams g = interpolateGaussian(trilinearCell(dims, x, y, z), mean, stddev);
        double v[4];
        expectedTfGaussian(tf, g.mean, g.sigma, v);
        return detail::toRgba(v);
    }
    UDVR_CPU_GPU void voxelSupport(std::size_t voxel, float& lo, float& hi) const {
        const double s = kSupportSigmas * static_cast<double>(stddev[voxel]);
        lo = static_cast<float>(mean[voxel] - s);
        hi = static_cast<float>(mean[voxel] + s);
    }
};

/// GMM (ordered): Σ_k π_k E_k with rank-wise interpolated π, μ, σ (Σπ normalised to 1).
struct GmmOrderedKernel {
    int dims[3];
    const float* gmm;  // 3K per voxel
    int components;    // K ≤ kMaxGmmComponents
    TfTable tf;

    UDVR_CPU_GPU Rgba classifyAt(float x, float y, float z) const {
        double pi[kMaxGmmComponents], mu[kMaxGmmComponents], sigma[kMaxGmmComponents];
        interpolateGmmOrdered(trilinearCell(dims, x, y, z), gmm, components, pi, mu, sigma);
        double acc[4] = {0, 0, 0, 0};
        for (int k = 0; k < components; ++k) {
            if (pi[k] == 0.0) continue;
            double v[4];
            expectedTfGaussian(tf, mu[k], sigma[k], v);
            for (int ch = 0; ch < 4; ++ch) acc[ch] += pi[k] * v[ch];
        }
        return detail::toRgba(acc);
    }
    UDVR_CPU_GPU void voxelSupport(std::size_t voxel, float& lo, float& hi) const {
        const float* g = gmm + voxel * 3 * static_cast<std::size_t>(components);
        double l = INFINITY, h = -INFINITY;
        for (int k = 0; k < components; ++k) {
            if (!(g[k] > 0.f)) continue;
            const double s = kSupportSigmas * static_cast<double>(g[2 * components + k]);
            l = std::fmin(l, g[components + k] - s);
            h = std::fmax(h, g[components + k] + s);
        }
        if (l > h) l = h = g[components];  // all weights 0: any component mean
        lo = static_cast<float>(l);
        hi = static_cast<float>(h);
    }
};

/// Quantile range (Eq. 4) over the population of quantiles j0+1 … j1 of boundaries stored with
/// `stride` floats per voxel. Serves quantile-range (0…q), the quartile views (0…q/4, q/4…3q/4,
/// 3q/4…q) and iqr (the 2-boundary iqr array, 0…1).
struct QuantileRangeKernel {
    int dims[3];
    const float* boundaries;
    int stride;  // boundaries per voxel
    int j0, j1;  // population: quantiles j0+1 … j1
    TfTable tf;

    UDVR_CPU_GPU Rgba classifyAt(float x, float y, float z) const {
        const TrilinearCell cell = trilinearCell(dims, x, y, z);
        switch (j1 - j0) {  // the common populations get a fixed-size vectorised path
            case 1:
                return fixed<2>(cell);
            case 2:
                return fixed<3>(cell);
            case 4:
                return fixed<5>(cell);
            case 8:
                return fixed<9>(cell);
            case 16:
                return fixed<17>(cell);
            default:
                break;
        }
        const std::size_t s = static_cast<std::size_t>(stride);
        auto boundary = [&](int j) { return interpolateBoundary(cell, boundaries, s, j); };
        double v[4];
        expectedTfQuantileRange(tf, boundary, j0, j1, v);
        return detail::toRgba(v);
    }
    /// expectedTfQuantileRange for N = j1 − j0 + 1 boundaries, interpolated in one vectorised
    /// pass, with the pieces found by walking up (boundaries are non-decreasing): same values.
    template <int N>
    UDVR_CPU_GPU Rgba fixed(const TrilinearCell& cell) const {
        double b[N];
        detail::interpolateBoundaryRun<N>(cell, boundaries, static_cast<std::size_t>(stride), j0,
                                          b);
        double v[4] = {0, 0, 0, 0};
        int kPrev = tf.pieceOf(b[0]);
        for (int j = 1; j < N; ++j) {
            const int k = detail::nextPiece(tf, kPrev, b[j - 1], b[j]);
            double m[4];
            tf.meanOver(b[j - 1], b[j], kPrev, k, m);
            for (int ch = 0; ch < 4; ++ch) v[ch] += m[ch];
            kPrev = k;
        }
        const double inv = 1.0 / (N - 1);
        for (int ch = 0; ch < 4; ++ch) v[ch] *= inv;
        return detail::toRgba(v);
    }
    UDVR_CPU_GPU void voxelSupport(std::size_t voxel, float& lo, float& hi) const {
        const float* b = boundaries + voxel * static_cast<std::size_t>(stride);
        lo = b[j0];
        hi = b[j1];
    }
};

/// Quantile mean (Eq. 5) with density weights p_j ∝ 1/w_j (`quantile-mean`) or equal weights
/// (`quantile-mean-mass`).
struct QuantileMeanKernel {
    int dims[3];
    const float* quantiles;
    int q;
    bool densityWeights;
    double zeroWidth;  // data units
    TfTable tf;

    UDVR_CPU_GPU Rgba classifyAt(float x, float y, float z) const {
        const TrilinearCell cell = trilinearCell(dims, x, y, z);
        switch (q) {  // the common q get a fixed-size vectorised path
            case 2:
                return fixed<3>(cell);
            case 4:
                return fixed<5>(cell);
            case 8:
                return fixed<9>(cell);
            case 16:
                return fixed<17>(cell);
            default:
                break;
        }
        const std::size_t s = static_cast<std::size_t>(q) + 1;
        auto boundary = [&](int j) { return interpolateBoundary(cell, quantiles, s, j); };
        double v[4];
        expectedTfQuantileMean(tf, boundary, q, densityWeights, zeroWidth, v);
        return detail::toRgba(v);
    }
    /// expectedTfQuantileMean for N = q + 1 boundaries interpolated in one vectorised pass, the
    /// midpoints' pieces found by walking up (midpoints are non-decreasing): the same operations
    /// per quantile in the same order, so the same values.
    template <int N>
    UDVR_CPU_GPU Rgba fixed(const TrilinearCell& cell) const {
        double b[N];
        detail::interpolateBoundaryRun<N>(cell, quantiles, N, 0, b);
        // Widths, midpoints and weights of all quantiles first (vectorised divisions).
        double w[N - 1], mid[N - 1], weight[N - 1];
        for (int j = 0; j < N - 1; ++j) {
            w[j] = b[j + 1] - b[j];
            mid[j] = 0.5 * (b[j] + b[j + 1]);
            weight[j] = densityWeights ? 1.0 / w[j] : 1.0;  // 1/q cancels
        }
        double sum[4] = {0, 0, 0, 0}, zeroSum[4] = {0, 0, 0, 0};
        double wsum = 0.0;
        int zeroCount = 0;
        int k = tf.pieceOf(mid[0]);
        for (int j = 0; j < N - 1; ++j) {
            if (j > 0) k = detail::nextPiece(tf, k, mid[j - 1], mid[j]);
            double e[4];
            tf.evalPiece(k, mid[j], e);
            if (densityWeights && w[j] <= zeroWidth) {
                ++zeroCount;
                for (int ch = 0; ch < 4; ++ch) zeroSum[ch] += e[ch];
            } else {
                for (int ch = 0; ch < 4; ++ch) sum[ch] += weight[j] * e[ch];
                wsum += weight[j];
            }
        }
        double v[4];
        for (int ch = 0; ch < 4; ++ch)
            v[ch] = zeroCount > 0 ? zeroSum[ch] / zeroCount : sum[ch] / wsum;
        return detail::toRgba(v);
    }
    /// The TF is only evaluated at quantile midpoints, and the midpoints at a point interpolate
    /// the corners' midpoints (m_j(p) = Σ w_c m_{j,c}), so [m_0, m_{q−1}] of each voxel is a
    /// support: narrower than [b_0, b_q] by half the outer quantiles (often the outliers).
    UDVR_CPU_GPU void voxelSupport(std::size_t voxel, float& lo, float& hi) const {
        const float* b = quantiles + voxel * (static_cast<std::size_t>(q) + 1);
        lo = static_cast<float>(0.5 * (static_cast<double>(b[0]) + b[1]));
        hi = static_cast<float>(0.5 * (static_cast<double>(b[q - 1]) + b[q]));
    }
};

/// Options that change classification but are not part of the model file.
struct ClassifyOptions {
    int quartileDivisor = 4;     // quartile views need q divisible by this
    bool uniformMinMax = false;  // `--uniform-width minmax`: U[min, max] instead of μ ± √3σ
};

/// The model's data range (SPEC §4): [min b_0, max b_q] with quantiles, else [min of `min`,
/// max of `max`], else the range of `mean`. Used to scale zero-width thresholds.
std::pair<double, double> modelDataRange(const ModelVolume& model);

/// Throws UdvrError unless `model` has the arrays `kind` needs (sizes checked too).
void checkModelHasArrays(const ModelVolume& model, ModelKind kind,
                         const ClassifyOptions& options = {});

/// The quantile population [j0, j1] (boundary indices) of a quantile-range-family kind for q
/// quantiles: quantile-range (0, q), quartile views (0, q/4), (q/4, 3q/4), (3q/4, q).
std::pair<int, int> quantilePopulation(ModelKind kind, int q, const ClassifyOptions& options = {});

/// Call f(kernel) with the kernel for `kind` built over `model` and `tf` (the TF table lives for
/// the call). Throws UdvrError when the model file lacks an array the kind needs. gmm-mc has no
/// per-sample kernel (render only: realizations are mean fields, see makeMeanKernel).
template <class F>
void withKernel(const ModelVolume& model, ModelKind kind, const TransferFunction1D& tf,
                const ClassifyOptions& options, F&& f) {
    checkModelHasArrays(model, kind, options);
    const TfTableStorage table(tf);
    const int dims[3] = {model.grid.dims[0], model.grid.dims[1], model.grid.dims[2]};
    const auto range = modelDataRange(model);
    const double span = range.second - range.first;
    switch (kind) {
        case ModelKind::Mean: {
            MeanKernel k{{dims[0], dims[1], dims[2]}, model.mean.data(), table.table()};
            f(k);
            return;
        }
        case ModelKind::Uniform: {
            UniformKernel k{{dims[0], dims[1], dims[2]},
                            options.uniformMinMax ? model.min.data() : model.mean.data(),
                            options.uniformMinMax ? model.max.data() : model.stddev.data(),
                            options.uniformMinMax,
                            kUniformTinyWidth * span,
                            table.table()};
            f(k);
            return;
        }
        case ModelKind::Gaussian: {
            GaussianKernel k{
                {dims[0], dims[1], dims[2]}, model.mean.data(), model.stddev.data(), table.table()};
            f(k);
            return;
        }
        case ModelKind::GmmOrdered: {
            GmmOrderedKernel k{
                {dims[0], dims[1], dims[2]}, model.gmm.data(), model.gmmComponents, table.table()};
            f(k);
            return;
        }
        case ModelKind::QuantileRange:
        case ModelKind::QuartileLower:
        case ModelKind::QuartileMiddle:
        case ModelKind::QuartileUpper: {
            const auto pop = quantilePopulation(kind, model.quantileCount, options);
            QuantileRangeKernel k{{dims[0], dims[1], dims[2]},
                                  model.quantiles.data(),
                                  model.quantileCount + 1,
                                  pop.first,
                                  pop.second,
                                  table.table()};
            f(k);
            return;
        }
        case ModelKind::Iqr: {
            QuantileRangeKernel k{
                {dims[0], dims[1], dims[2]}, model.iqr.data(), 2, 0, 1, table.table()};
            f(k);
            return;
        }
        case ModelKind::QuantileMean:
        case ModelKind::QuantileMeanMass: {
            QuantileMeanKernel k{{dims[0], dims[1], dims[2]}, model.quantiles.data(),
                                 model.quantileCount,         kind == ModelKind::QuantileMean,
                                 kQuantileZeroWidth * span,   table.table()};
            f(k);
            return;
        }
        case ModelKind::GmmMc:
            UDVR_FAIL(
                "model 'gmm-mc' has no per-sample kernel: it is rendered as the average of "
                "mean-field realizations");
    }
    UDVR_FAIL("model '" << modelName(kind) << "' has no kernel");
}

/// withKernel with default options.
template <class F>
void withKernel(const ModelVolume& model, ModelKind kind, const TransferFunction1D& tf, F&& f) {
    withKernel(model, kind, tf, ClassifyOptions{}, std::forward<F>(f));
}

/// A mean-field kernel over any per-voxel value array (e.g. one gmm-mc realization) with `dims`
/// points; `table` must outlive the kernel.
inline MeanKernel makeMeanKernel(const int dims[3], const float* values, const TfTable& table) {
    return MeanKernel{{dims[0], dims[1], dims[2]}, values, table};
}

}  // namespace udvr
