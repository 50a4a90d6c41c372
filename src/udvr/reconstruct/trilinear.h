#pragma once
// Trilinear reconstruction weights (SPEC §1, §3) at an index-space point.
#include <cstddef>

#include "udvr/util/check.h"
#include "udvr/util/grid.h"

namespace udvr {

/// The 8 corners of the cell holding an index-space point and their trilinear weights.
/// Corner c = (c&1, (c>>1)&1, (c>>2)&1) offsets from the base point; weights sum to 1.
struct TrilinearCell {
    std::size_t corner[8];  // linear voxel indices
    float weight[8];        // w_c ≥ 0
};

/// Cell and weights at index-space point (x,y,z), clamped to [0, dim-1] per axis. Points on the
/// last plane use the cell below it with weight 0 on the far side, so no index runs past the grid.
UDVR_CPU_GPU inline TrilinearCell trilinearCell(const int dims[3], float x, float y, float z) {
    float p[3] = {x, y, z};
    int base[3];
    float frac[3];
    for (int a = 0; a < 3; ++a) {
        float maxIndex = static_cast<float>(dims[a] - 1);
        float v = p[a] < 0.f ? 0.f : (p[a] > maxIndex ? maxIndex : p[a]);
        int b = static_cast<int>(v);
        if (b >= dims[a] - 1) b = dims[a] > 1 ? dims[a] - 2 : 0;
        base[a] = b;
        frac[a] = dims[a] > 1 ? v - static_cast<float>(b) : 0.f;
    }
    const std::size_t sx = 1;
    const std::size_t sy = static_cast<std::size_t>(dims[0]);
    const std::size_t sz = sy * static_cast<std::size_t>(dims[1]);
    const std::size_t o = static_cast<std::size_t>(base[0]) * sx +
                          static_cast<std::size_t>(base[1]) * sy +
                          static_cast<std::size_t>(base[2]) * sz;
    const std::size_t dx = dims[0] > 1 ? sx : 0, dy = dims[1] > 1 ? sy : 0,
                      dz = dims[2] > 1 ? sz : 0;
    TrilinearCell cell;
    for (int c = 0; c < 8; ++c) {
        int cx = c & 1, cy = (c >> 1) & 1, cz = (c >> 2) & 1;
        cell.corner[c] = o + (cx ? dx : 0) + (cy ? dy : 0) + (cz ? dz : 0);
        float wx = cx ? frac[0] : 1.f - frac[0];
        float wy = cy ? frac[1] : 1.f - frac[1];
        float wz = cz ? frac[2] : 1.f - frac[2];
        cell.weight[c] = wx * wy * wz;
    }
    return cell;
}

}  // namespace udvr
