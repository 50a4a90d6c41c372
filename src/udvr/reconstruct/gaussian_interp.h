#pragma once
// Gaussian reconstruction (SPEC §3): X = Σ_c w_c X_c with independent X_c ~ N(μ_c, σ_c²) is
// N(Σ w_c μ_c, Σ w_c² σ_c²). One body over T (double, float, lanes::Vf), as reconstruct/cell.h.
#include <cstdint>

#include "udvr/reconstruct/cell.h"

namespace udvr {

/// μ = Σ w_c μ_c (lerps) and σ = sqrt(Σ_c (w_c σ_c)²) at a cell, data units; σ = 0 where the
/// variance is 0 or NaN (the point mass at μ). Lanes outside `live` are 0.
template <class T>
UDVR_CPU_GPU UDVR_INLINE void gaussianAt(const CellGeometry& g, const float* mean,
                                         const float* stddev, const Cell<T>& c,
                                         lanes::MaskOf<T> live, T& mu, T& sigma) {
    mu = trilinear(g, mean, 1, c, live);
    // w_c are the products of (1 − f) and f per axis; one x-edge of σ per (y, z) corner pair.
    const T one = lanes::splat<T>(1);
    const T gx[2] = {one - c.fx, c.fx}, gy[2] = {one - c.fy, c.fy}, gz[2] = {one - c.fz, c.fz};
    const std::int64_t offsets[4] = {0, g.next[1], g.next[2], g.next[1] + g.next[2]};
    T var{};
    for (int r = 0; r < 4; ++r) {
        T s0, s1;
        edgeOf<T>(g, stddev, 1, c.base, offsets[r], live, s0, s1);
        const T wyz = gy[r & 1] * gz[r >> 1];
        const T a0 = gx[0] * wyz * s0, a1 = gx[1] * wyz * s1;
        var = lanes::fma(a0, a0, lanes::fma(a1, a1, var));
    }
    sigma = lanes::sqrt(lanes::select(var > 0, var, T{}));
}

}  // namespace udvr
