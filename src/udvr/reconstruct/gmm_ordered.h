#pragma once
// Rank-wise GMM interpolation, "GMM (ordered)" (Hollister & Pang 2013; Athawale et al. 2021 §3.2;
// SPEC §3): components are sorted by mean at every voxel, and the k'th component at p has
// π_k, μ_k, σ_k each interpolated trilinearly from the corners' k'th components.
#include <cstddef>

#include "udvr/reconstruct/trilinear.h"

namespace udvr {

/// Largest K the kernels handle (stack arrays).
inline constexpr int kMaxGmmComponents = 16;

/// π_k (normalised to Σπ = 1 unless all are 0), μ_k, σ_k at a cell; gmm holds 3K floats per
/// voxel (π_1..π_K, μ_1..μ_K, σ_1..σ_K). Returns Σπ before normalisation.
UDVR_CPU_GPU inline double interpolateGmmOrdered(const TrilinearCell& cell, const float* gmm, int k,
                                                 double* pi, double* mu, double* sigma) {
    const std::size_t stride = 3 * static_cast<std::size_t>(k);
    for (int i = 0; i < k; ++i) pi[i] = mu[i] = sigma[i] = 0.0;
    for (int c = 0; c < 8; ++c) {
        const double w = cell.weight[c];
        if (w == 0.0) continue;
        const float* g = gmm + cell.corner[c] * stride;
        for (int i = 0; i < k; ++i) {
            pi[i] += w * static_cast<double>(g[i]);
            mu[i] += w * static_cast<double>(g[k + i]);
            sigma[i] += w * static_cast<double>(g[2 * k + i]);
        }
    }
    double total = 0.0;
    for (int i = 0; i < k; ++i) total += pi[i];
    if (total > 0.0)
        for (int i = 0; i < k; ++i) pi[i] /= total;
    return total;
}

}  // namespace udvr
