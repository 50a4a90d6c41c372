#pragma once
// Quantile interpolation in 3D (Athawale et al. 2021, §3.2, Eq. 2; SPEC §3): the j'th boundary of
// the interpolated distribution is the trilinear interpolation of the corners' j'th boundaries,
// so each quantile keeps its probability (1/q for even levels, t_j − t_{j−1} for the uneven
// levels of QuantileLevels) and its width w_j(p) = Σ_c w_c w_{j,c} (the paper's closed form
// Pr(Q_j) = (1/q)/w_j). The interpolated density is piecewise constant: mass_j/w_j on
// [b_{j−1}(p), b_j(p)]. Cost O(q) per point.
#include <cstddef>
#include <type_traits>
#include <utility>

#include "udvr/reconstruct/cell.h"

namespace udvr {

/// The levels of a run of quantile boundaries (SPEC §7 `quantile_levels`, paper §6's uneven
/// quantiles): quantile j of the run, between its boundaries j − 1 and j, holds probability
/// mass t_{first+j} − t_{first+j−1}. Null levels are even levels, where each quantile's mass is
/// taken as 1 (weights are relative), so even levels keep the arithmetic of equal weights.
struct QuantileLevels {
    const double* levels = nullptr;  // t_0 … t_q of the model; null: even
    int first = 0;                   // the run's first boundary

    /// Mass of quantile j ≥ 1 of the run.
    UDVR_CPU_GPU double mass(int j) const {
        return levels ? levels[first + j] - levels[first + j - 1] : 1.0;
    }
    /// 1 / (the run's mass over boundaries 0 … count − 1), in S.
    template <class S>
    UDVR_CPU_GPU S inverseTotal(int count) const {
        return levels ? static_cast<S>(1.0 / (levels[first + count - 1] - levels[first]))
                      : S(1) / static_cast<S>(count - 1);
    }
};

/// Eq. 2 at one point, the one body of every path (a scalar sample, lanes of samples
/// gathered, a batch's rows with one sample's place splatted, AVX-512's pairs of samples):
/// corner[k] = b_{j,c} at corner c = k = (k&1, k>>1&1, k>>2&1) of the point's cell, f = its
/// fractions along x, y, z. Returns the boundary b_j(p) = Σ_c w_c b_{j,c} by lerps
/// u + f·(v − u) along x, then y, then z (trilinear's arithmetic: equal corners give equal
/// values). With `width`, also *width = w_j(p) = Σ_c w_c (b_{j+1,c} − b_{j,c}) from
/// next[k] = b_{j+1,c}: from the corners' own widths — not the difference of two interpolated
/// boundaries, which loses the digits of |b| that 1/w would then magnify — and blended as
/// (1 − f)·u + f·v, two non-negative terms, not by lerps: u + f·(v − u) cancels near a corner
/// of width 0 beside corners of large widths (float: an absolute error ~ulp(u), 0.4 % of a width
/// of 2e−6 in a test). On the 64³ tangle model (q = 8, 2·10⁶ random points, float lanes against
/// the same sum in double) the largest relative error of a width is 2.8e−7 this way, 1.9e−6 by
/// lerps and 3.5e−7 as the sum of the 8 trilinear weights' terms. ≥ 0 wherever the corners'
/// boundaries are sorted.
template <class V>
UDVR_CPU_GPU UDVR_INLINE V interpolatedBoundary(const V corner[8], const V f[3],
                                                const V* next = nullptr, V* width = nullptr) {
    if (width) {
        const V one = lanes::splat<V>(1), g[3] = {one - f[0], one - f[1], one - f[2]};
        const auto mix = [&](V u, V v, int a)
                             UDVR_INLINE_LAMBDA { return lanes::fma(f[a], v, g[a] * u); };
        V d[8];
        for (int k = 0; k < 8; ++k) d[k] = next[k] - corner[k];
        *width = mix(mix(mix(d[0], d[1], 0), mix(d[2], d[3], 0), 1),
                     mix(mix(d[4], d[5], 0), mix(d[6], d[7], 0), 1), 2);
    }
    return lerp(lerp(lerp(corner[0], corner[1], f[0]), lerp(corner[2], corner[3], f[0]), f[1]),
                lerp(lerp(corner[4], corner[5], f[0]), lerp(corner[6], corner[7], f[0]), f[1]),
                f[2]);
}

/// Boundary j of a voxel-major array with `stride` floats per voxel at the 8 corners of a cell,
/// corner k = (k&1, k>>1&1, k>>2&1) in out[k] (lanes outside `live` are 0).
template <class T>
UDVR_CPU_GPU UDVR_INLINE void cornersAt(const CellGeometry& g, const float* data, int stride, int j,
                                        const Cell<T>& c, lanes::MaskOf<T> live, T out[8]) {
    const std::int64_t oy = g.next[1], oz = g.next[2];
    const std::int64_t offsets[4] = {0, oy, oz, oz + oy};
    for (int r = 0; r < 4; ++r)
        edgeOf<T>(g, data + j, stride, c.base, offsets[r], live, out[2 * r], out[2 * r + 1]);
}

/// Boundary j of a voxel-major array with `stride` floats per voxel, interpolated at a cell
/// (Eq. 2, interpolatedBoundary). Lanes outside `live` are 0.
template <class T>
UDVR_CPU_GPU UDVR_INLINE T boundaryAt(const CellGeometry& g, const float* data, int stride, int j,
                                      const Cell<T>& c, lanes::MaskOf<T> live) {
    T corner[8];
    cornersAt<T>(g, data, stride, j, c, live, corner);
    const T f[3] = {c.fx, c.fy, c.fz};
    return interpolatedBoundary(corner, f);
}

/// The width b_{j+1} − b_j at a cell (Eq. 2, interpolatedBoundary: from the corners' own
/// widths).
template <class T>
UDVR_CPU_GPU UDVR_INLINE T widthAt(const CellGeometry& g, const float* data, int stride, int j,
                                   const Cell<T>& c, lanes::MaskOf<T> live) {
    T corner[8], next[8], width;
    cornersAt<T>(g, data, stride, j, c, live, corner);
    cornersAt<T>(g, data, stride, j + 1, c, live, next);
    const T f[3] = {c.fx, c.fy, c.fz};
    interpolatedBoundary(corner, f, next, &width);
    return width;
}

/// Boundaries a batch's row path handles (two blocks of kWidth): q ≤ 31 on AVX-512, 15 on
/// AVX2, 7 on SSE2/NEON; larger populations gather each boundary (boundaryAt).
inline constexpr int kMaxRowBoundaries = 2 * lanes::kWidth;

/// boundaryAt and widthAt for boundaries first … first + count − 1 (b and w hold count vectors
/// rounded up to a multiple of kWidth: kMaxRowBoundaries for the quantile kernels' rows)
/// of a batch's samples at once: per block of kWidth boundaries, each live sample's 8 corner
/// rows are one vector each (masked loads), blended by interpolatedBoundary with the sample's
/// fractions splatted, then the samples' rows are transposed, so b[j] holds boundary
/// first + j of every sample and the classification runs per boundary without horizontal sums.
/// With `w`, also w[j] = the width of boundaries j, j + 1 (j < count − 1). Lanes outside `live`
/// are 0.
UDVR_INLINE void boundaryRows(const CellGeometry& g, const float* data, int stride, int first,
                              int count, const Cell<lanes::Vf>& c, lanes::Mask live, lanes::Vf* b,
                              lanes::Vf* w = nullptr) {
    using lanes::Vf;
    constexpr int W = lanes::kWidth;
    const std::int64_t ox = g.next[0], oy = g.next[1], oz = g.next[2];
    const std::int64_t offsets[8] = {0, ox, oy, oy + ox, oz, oz + ox, oz + oy, oz + oy + ox};
    const std::uint32_t liveBits = lanes::bits(live);
    alignas(64) std::int32_t base[W];
    alignas(64) float f[3][W];
    lanes::store(base, c.base);
    lanes::store(f[0], c.fx);
    lanes::store(f[1], c.fy);
    lanes::store(f[2], c.fz);
    // With widths, a last boundary alone in its block is b_{n−2} + w_{n−2} (saves a block).
    const int rowCount = w && count > 1 && (count - 1) % W == 0 ? count - 1 : count;
    for (int block = 0; block * W < count - 1 || block * W < rowCount; ++block) {
        const int j0 = block * W;
        const auto clampW = [](int n) { return n < 0 ? 0 : (n < W ? n : W); };
        const int nb = clampW(rowCount - j0);           // boundaries in this block
        const int nw = w ? clampW(count - 1 - j0) : 0;  // widths in this block
        // Each block is transposed in place in the outputs (they hold 2·kWidth vectors).
        Vf* rows = b + j0;
        Vf* widths = w ? w + j0 : nullptr;
        for (int l = 0; l < W; ++l) {
            rows[l] = Vf{};
            if (nw > 0) widths[l] = Vf{};
            if (!(liveBits >> l & 1u)) continue;
            const Vf at[3] = {lanes::splat<Vf>(f[0][l]), lanes::splat<Vf>(f[1][l]),
                              lanes::splat<Vf>(f[2][l])};
            const float* row[8];
            Vf corner[8];
            for (int k = 0; k < 8; ++k) {
                row[k] =
                    data + (base[l] + offsets[k]) * static_cast<std::int64_t>(stride) + first + j0;
                corner[k] = lanes::loadFirst(row[k], nb);
            }
            if (nw > 0) {
                // Each corner's b_{j+1} in lane j: by a lane shift where the block holds
                // b_{j+1} of its every width, else from a second load one boundary on.
                Vf next[8];
                for (int k = 0; k < 8; ++k)
                    next[k] = nw < nb ? lanes::shiftDown1(corner[k], Vf{})
                                      : lanes::loadFirst(row[k] + 1, nw);
                rows[l] = interpolatedBoundary(corner, at, next, &widths[l]);
            } else {
                rows[l] = interpolatedBoundary(corner, at);
            }
        }
        if (nb > 0) lanes::transpose(rows);
        if (nw > 0) lanes::transpose(widths);
    }
    if (rowCount < count) b[count - 1] = b[count - 2] + w[count - 2];
}

/// boundaryRows for an array of exactly 4 floats per voxel (gridGradients' ValueRows), all 4:
/// out[k] = the trilinear blend of float k, bit for bit as boundaryRows and trilinear (lerps
/// along x, then y, then z); lanes outside `live` are 0. On AVX-512 with x-neighbours adjacent,
/// two samples share a register: each row of a cell (its two x-corners, 8 adjacent floats)
/// is one 256-bit half, so 4 registers hold the 8 corners of two samples, and the 16 results
/// go into place by a 4×4 transpose within 128-bit blocks (512² tangle mean with a TF2, one
/// thread: 107 → 97 ms against boundaryRows' per-sample corners and 16×16 transpose).
/// Elsewhere boundaryRows.
UDVR_INLINE void rows4(const CellGeometry& g, const float* data, const Cell<lanes::Vf>& c,
                       lanes::Mask live, lanes::Vf out[4]) {
#if defined(__AVX512F__)
    if (g.next32[0] == 1) {
        using lanes::Vf;
        const std::uint32_t liveBits = lanes::bits(live);
        alignas(64) std::int32_t base[16];
        lanes::store(base, c.base);
        const std::ptrdiff_t rowOffset[4] = {0, g.next[1], g.next[2], g.next[2] + g.next[1]};
        Vf z[8];  // pair p: sample 2p's 4 floats in block 0, sample 2p + 1's in block 2
        const auto pair = [&]<int P>(std::integral_constant<int, P>) {
            constexpr int l = 2 * P;
            const std::uint32_t both = liveBits >> l & 3u;
            if (!both) {
                z[P] = Vf{};
                return;
            }
            static constexpr float kZero[8] = {};
            const float* p0 = both & 1u ? data + 4 * static_cast<std::ptrdiff_t>(base[l]) : nullptr;
            const float* p1 =
                both & 2u ? data + 4 * static_cast<std::ptrdiff_t>(base[l + 1]) : nullptr;
            const Vf at[3] = {lanes::pairHalves<l>(c.fx), lanes::pairHalves<l>(c.fy),
                              lanes::pairHalves<l>(c.fz)};
            Vf corner[8];
            for (int r = 0; r < 4; ++r) {
                // Named, not passed as arguments (which GCC evaluates right to left): in this
                // order GCC 12 emits the same code as for two loads in statements.
                const float* lo = p0 ? p0 + 4 * rowOffset[r] : kZero;
                const float* hi = p1 ? p1 + 4 * rowOffset[r] : kZero;
                // Each half's corner 0 and, with its blocks swapped, corner 1.
                corner[2 * r] = lanes::loadHalves(lo, hi);
                corner[2 * r + 1] = lanes::swapBlocksInHalves(corner[2 * r]);
            }
            z[P] = interpolatedBoundary(corner, at);
        };
        [&]<int... P>(std::integer_sequence<int, P...>) {
            (pair(std::integral_constant<int, P>{}), ...);
        }
        (std::make_integer_sequence<int, 8>{});
        // q[m]: samples m, 4 + m, 8 + m, 12 + m in blocks 0 … 3.
        const Vf a02 = lanes::evenBlocks(z[0], z[2]), a46 = lanes::evenBlocks(z[4], z[6]);
        const Vf b02 = lanes::evenBlocks(z[1], z[3]), b46 = lanes::evenBlocks(z[5], z[7]);
        const Vf q[4] = {lanes::evenBlocks(a02, a46), lanes::oddBlocks(a02, a46),
                         lanes::evenBlocks(b02, b46), lanes::oddBlocks(b02, b46)};
        // 4×4 transpose within each block: out[k] block j = float k of samples 4j … 4j + 3.
        lanes::transposeBlocks4(q, out);
        for (int k = 0; k < 4; ++k) out[k] = lanes::select(live, out[k], Vf{});
        return;
    }
#endif
    lanes::Vf b[lanes::kWidth];
    boundaryRows(g, data, 4, 0, 4, c, live, b);
    for (int k = 0; k < 4; ++k) out[k] = b[k];
}

/// The paper's Eq. 2 written as in the paper: Pr(Q_j) at cell parameters (α, β, γ) from the
/// corners' densities Pr_1…Pr_8 (the paper's order: Pr_1/Pr_2 across α, pairs across β,
/// quadruples across γ; α weights the width of Pr_2's vertex, β of the (3,4) pair, γ of the
/// (5..8) quadruple). Kept as a reference for tests; equals (1/q)/w_j(p).
inline double paperQuantileDensity(double alpha, double beta, double gamma, const double pr[8]) {
    const double t1 = alpha * pr[0] + (1 - alpha) * pr[1];
    const double t2 = alpha * pr[2] + (1 - alpha) * pr[3];
    const double t3 = alpha * pr[4] + (1 - alpha) * pr[5];
    const double t4 = alpha * pr[6] + (1 - alpha) * pr[7];
    const double t5 = beta * pr[0] * pr[1] / t1 + (1 - beta) * pr[2] * pr[3] / t2;
    const double t6 = beta * pr[4] * pr[5] / t3 + (1 - beta) * pr[6] * pr[7] / t4;
    const double t7 = gamma * pr[0] * pr[1] * pr[2] * pr[3] / (t1 * t2 * t5) +
                      (1 - gamma) * pr[4] * pr[5] * pr[6] * pr[7] / (t3 * t4 * t6);
    return pr[0] * pr[1] * pr[2] * pr[3] * pr[4] * pr[5] * pr[6] * pr[7] /
           (t1 * t2 * t3 * t4 * t5 * t6 * t7);
}

}  // namespace udvr
