#pragma once
// Quantile interpolation in 3D (Athawale et al. 2021, §3.2, Eq. 2; SPEC §3): the j'th boundary of
// the interpolated distribution is the trilinear interpolation of the corners' j'th boundaries,
// so each quantile keeps probability 1/q and its width w_j(p) = Σ_c w_c w_{j,c} (the paper's
// closed form Pr(Q_j) = (1/q)/w_j). The interpolated density is piecewise constant: 1/(q·w_j)
// on [b_{j−1}(p), b_j(p)]. Cost O(q) per point.
#include <cstddef>

#include "udvr/reconstruct/trilinear.h"

namespace udvr {

/// b_j(p) for j = j0…j1 into out[0 … j1−j0] (data units). `quantiles` holds q+1 boundaries per
/// voxel, contiguous. Summed in double in a fixed order, so b_j(p) stays non-decreasing in j.
UDVR_CPU_GPU inline void interpolateBoundaries(const TrilinearCell& cell, const float* quantiles,
                                               int q, int j0, int j1, double* out) {
    const std::size_t stride = static_cast<std::size_t>(q) + 1;
    for (int j = j0; j <= j1; ++j) out[j - j0] = 0.0;
    for (int c = 0; c < 8; ++c) {
        const double w = cell.weight[c];
        if (w == 0.0) continue;
        const float* b = quantiles + cell.corner[c] * stride;
        for (int j = j0; j <= j1; ++j) out[j - j0] += w * static_cast<double>(b[j]);
    }
}

/// One interpolated boundary Σ_c w_c b_{j,c} (Eq. 2); `stride` floats per voxel (q+1).
UDVR_CPU_GPU inline double interpolateBoundary(const TrilinearCell& cell, const float* quantiles,
                                               std::size_t stride, int j) {
    double s = 0.0;
    for (int c = 0; c < 8; ++c)
        s += static_cast<double>(cell.weight[c]) *
             static_cast<double>(quantiles[cell.corner[c] * stride + static_cast<std::size_t>(j)]);
    return s;
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
