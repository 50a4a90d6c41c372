#pragma once
// Gradients of SPEC §9 (paper §4.1): at a grid point, central differences in world units,
// (f[i+1] − f[i−1]) / (2·s), one-sided (f[i+1] − f[i]) / s at the first and last point, 0 along
// an axis of one point; at a sample, the 8 corners' grid gradients blended trilinearly. So the
// gradient Y at a sample is linear in at most 32 voxel values: Y = Σ_i g_i X_i.
//
// One index rule covers every case: along an axis of n points, point i differences
// f[hi] − f[lo] over (hi − lo)·s with lo = max(i − 1, 0), hi = min(i + 1, n − 1) (hi = lo on
// a one-point axis: gradient 0).
#include <array>
#include <cstdint>

#include "udvr/reconstruct/cell.h"

namespace udvr {

/// Per axis: index step to the lower/upper neighbour of each point and 1/((hi − lo)·s).
struct GradientGeometry {
    std::array<double, 3> invSpacing{1, 1, 1};  // 1 / world spacing

    GradientGeometry() = default;
    explicit GradientGeometry(const Grid3& g) {
        for (int a = 0; a < 3; ++a) invSpacing[a] = 1.0 / g.spacing[a];
    }
    /// Neighbours lo, hi of point i along an axis of n points and the difference's scale
    /// (0 on a one-point axis).
    UDVR_CPU_GPU static void stencil(int i, int n, double invS, int& lo, int& hi, double& scale) {
        lo = i > 0 ? i - 1 : 0;
        hi = i + 1 < n ? i + 1 : n - 1;
        scale = hi > lo ? invS / (hi - lo) : 0.0;
    }
};

/// The grid gradient (world units) of `values` (perVoxel floats per voxel, the first read) at
/// grid point (i, j, k).
UDVR_CPU_GPU inline std::array<double, 3> gridGradient(const CellGeometry& g,
                                                       const GradientGeometry& gg,
                                                       const float* values, int perVoxel, int i,
                                                       int j, int k) {
    const int idx[3] = {i, j, k};
    const std::int64_t base = i * g.stride[0] + j * g.stride[1] + k * g.stride[2];
    std::array<double, 3> out{};
    for (int a = 0; a < 3; ++a) {
        int lo, hi;
        double scale;
        GradientGeometry::stencil(idx[a], g.dims[a], gg.invSpacing[a], lo, hi, scale);
        if (scale == 0.0) continue;
        const std::int64_t vl = base + (lo - idx[a]) * g.stride[a];
        const std::int64_t vh = base + (hi - idx[a]) * g.stride[a];
        out[a] = scale * (static_cast<double>(values[vh * perVoxel]) -
                          static_cast<double>(values[vl * perVoxel]));
    }
    return out;
}

/// The linear form of the gradient at a sample: Y = Σ_i coeff[i]·X_{voxel[i]} over `count` ≤ 32
/// distinct voxels (SPEC §9), for the models whose voxels are independent (gaussian, uniform).
struct GradientForm {
    int count = 0;
    std::int64_t voxel[32];
    double w[32];         // trilinear weight of the voxel in the value X (0 off the cell)
    double coeff[32][3];  // g_i, world units

    UDVR_CPU_GPU int slot(std::int64_t v) {
        for (int s = 0; s < count; ++s)
            if (voxel[s] == v) return s;
        voxel[count] = v;
        w[count] = 0.0;
        coeff[count][0] = coeff[count][1] = coeff[count][2] = 0.0;
        return count++;
    }
};

/// The gradient's linear form at a scalar cell.
UDVR_CPU_GPU inline GradientForm gradientFormAt(const CellGeometry& g, const GradientGeometry& gg,
                                                const Cell<double>& c) {
    GradientForm f;
    double w[8];
    trilinearWeights(c, w);
    // The cell's base point (i, j, k).
    const std::int64_t b = c.base;
    const std::array<int, 3> base = voxelIndices(g, b);
    for (int corner = 0; corner < 8; ++corner) {
        const std::int64_t v = cornerVoxel(g, b, corner);
        f.w[f.slot(v)] += w[corner];
        if (w[corner] == 0.0) continue;
        for (int a = 0; a < 3; ++a) {
            const int i = base[a] + (((corner >> a) & 1) && g.dims[a] > 1 ? 1 : 0);
            int lo, hi;
            double scale;
            GradientGeometry::stencil(i, g.dims[a], gg.invSpacing[a], lo, hi, scale);
            if (scale == 0.0) continue;
            f.coeff[f.slot(v + (hi - i) * g.stride[a])][a] += w[corner] * scale;
            f.coeff[f.slot(v + (lo - i) * g.stride[a])][a] -= w[corner] * scale;
        }
    }
    return f;
}

}  // namespace udvr
