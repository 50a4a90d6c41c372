#pragma once
// Quantile interpolation in 3D (Athawale et al. 2021, §3.2, Eq. 2; SPEC §3): the j'th boundary of
// the interpolated distribution is the trilinear interpolation of the corners' j'th boundaries,
// so each quantile keeps probability 1/q and its width w_j(p) = Σ_c w_c w_{j,c} (the paper's
// closed form Pr(Q_j) = (1/q)/w_j). The interpolated density is piecewise constant: 1/(q·w_j)
// on [b_{j−1}(p), b_j(p)]. Cost O(q) per point.
#include <cstddef>

#include "udvr/reconstruct/cell.h"

namespace udvr {

/// Boundary j of a voxel-major array with `stride` floats per voxel, interpolated at a cell
/// (Eq. 2): b_j(p) = Σ_c w_c b_{j,c} by lerps. Lanes outside `live` are 0.
template <class T>
UDVR_CPU_GPU UDVR_INLINE T boundaryAt(const CellGeometry& g, const float* data, int stride, int j,
                                      const Cell<T>& c, lanes::MaskOf<T> live) {
    return trilinearBy(g, c, [&](std::int64_t o, T& v0, T& v1) {
        edgeOf<T>(g, data + j, stride, c.base, o, live, v0, v1);
    });
}

/// The width b_{j+1} − b_j at a cell, interpolated from the corners' own widths — not the
/// difference of two interpolated boundaries, which loses the digits of |b| that 1/w would
/// then magnify. ≥ 0 wherever the corners' boundaries are sorted.
template <class T>
UDVR_CPU_GPU UDVR_INLINE T widthAt(const CellGeometry& g, const float* data, int stride, int j,
                                   const Cell<T>& c, lanes::MaskOf<T> live) {
    return trilinearBy(g, c, [&](std::int64_t o, T& v0, T& v1) {
        T u0, u1;
        edgeOf<T>(g, data + j, stride, c.base, o, live, v0, v1);
        edgeOf<T>(g, data + j + 1, stride, c.base, o, live, u0, u1);
        v0 = u0 - v0;
        v1 = u1 - v1;
    });
}

/// boundaryAt and widthAt for boundaries first … first + count − 1 (count ≤ 16) of 16 samples
/// at once: each live sample's 8 corner rows are one vector each (masked loads), blended by the
/// same lerps, then the 16 samples' rows are transposed, so b[j] holds boundary first + j of
/// every sample and the classification runs per boundary without horizontal sums. With `w`,
/// also w[j] = the width of boundaries j, j + 1 (j < count − 1). Lanes outside `live` are 0.
UDVR_INLINE void boundaryRows(const CellGeometry& g, const float* data, int stride, int first,
                              int count, const Cell<lanes::Vf>& c, lanes::Mask live,
                              lanes::Vf b[16], lanes::Vf* w = nullptr) {
    using lanes::Vf;
    const std::int64_t ox = g.next[0], oy = g.next[1], oz = g.next[2];
    const std::int64_t offsets[8] = {0, ox, oy, oy + ox, oz, oz + ox, oz + oy, oz + oy + ox};
    const std::uint32_t liveBits = lanes::bits(live);
    for (int l = 0; l < lanes::kWidth; ++l) {
        b[l] = Vf{};
        if (w) w[l] = Vf{};
        if (!(liveBits >> l & 1u)) continue;
        const Vf fx = lanes::splat<Vf>(c.fx[l]), fy = lanes::splat<Vf>(c.fy[l]),
                 fz = lanes::splat<Vf>(c.fz[l]);
        const auto blend = [&](const Vf* q) {
            return lerp(lerp(lerp(q[0], q[1], fx), lerp(q[2], q[3], fx), fy),
                        lerp(lerp(q[4], q[5], fx), lerp(q[6], q[7], fx), fy), fz);
        };
        Vf corner[8];
        for (int k = 0; k < 8; ++k)
            corner[k] = lanes::loadFirst(
                data + (c.base[l] + offsets[k]) * static_cast<std::int64_t>(stride) + first, count);
        b[l] = blend(corner);
        if (w) {
            Vf cw[8];  // each corner's b_{j+1} − b_j in lane j
            for (int k = 0; k < 8; ++k) cw[k] = lanes::shiftDown1(corner[k], Vf{}) - corner[k];
            w[l] = blend(cw);
        }
    }
    lanes::transpose16(b);
    if (w) lanes::transpose16(w);
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
