#pragma once
// Gaussian reconstruction (SPEC §3): X = Σ_c w_c X_c with independent X_c ~ N(μ_c, σ_c²) is
// N(Σ w_c μ_c, Σ w_c² σ_c²).
#include <cmath>

#include "udvr/reconstruct/trilinear.h"

namespace udvr {

/// Mean and standard deviation of a Gaussian, data units.
struct GaussianParams {
    double mean = 0.0, sigma = 0.0;
};

/// N(Σ w μ, Σ w² σ²) at a cell.
UDVR_CPU_GPU inline GaussianParams interpolateGaussian(const TrilinearCell& cell, const float* mean,
                                                       const float* stddev) {
    double m = 0.0, var = 0.0;
    for (int c = 0; c < 8; ++c) {
        const double w = cell.weight[c];
        const double s = stddev[cell.corner[c]];
        m += w * static_cast<double>(mean[cell.corner[c]]);
        var += w * w * s * s;
    }
    return GaussianParams{m, std::sqrt(var)};
}

/// Mean field Σ w_c μ_c (SPEC §3, `mean`), in float: the cheapest reconstruction.
UDVR_CPU_GPU inline float interpolateMean(const TrilinearCell& cell, const float* mean) {
    float v = 0.f;
    for (int c = 0; c < 8; ++c) v += cell.weight[c] * mean[cell.corner[c]];
    return v;
}

}  // namespace udvr
