#pragma once
// Rank-wise GMM interpolation, "GMM (ordered)" (Hollister & Pang 2013; Athawale et al. 2021 §3.2;
// SPEC §3): components are sorted by mean at every voxel, and the k'th component at a point has
// π_k, μ_k, σ_k each interpolated trilinearly from the corners' k'th components. One body over
// T (double, float, lanes::Vf), as reconstruct/cell.h.
#include "udvr/reconstruct/cell.h"

namespace udvr {

/// π_k (normalised to Σπ = 1 where Σπ > 0), μ_k, σ_k (data units) at a cell for k < K; `gmm`
/// holds 3K floats per voxel (π_1..π_K, μ_1..μ_K, σ_1..σ_K). Returns Σπ before normalisation.
/// Lanes outside `live` are 0.
template <class T>
UDVR_CPU_GPU UDVR_INLINE T gmmOrderedAt(const CellGeometry& g, const float* gmm, int K,
                                        const Cell<T>& c, lanes::MaskOf<T> live, T* pi, T* mu,
                                        T* sigma) {
    const int n = 3 * K;
    T total{};
    for (int i = 0; i < K; ++i) {
        pi[i] = trilinear(g, gmm + i, n, c, live);
        mu[i] = trilinear(g, gmm + K + i, n, c, live);
        sigma[i] = trilinear(g, gmm + 2 * K + i, n, c, live);
        total += pi[i];
    }
    const auto normalise = total > 0;
    const T inv = lanes::splat<T>(1) / total;
    for (int i = 0; i < K; ++i) pi[i] = lanes::select(normalise, pi[i] * inv, pi[i]);
    return total;
}

}  // namespace udvr
