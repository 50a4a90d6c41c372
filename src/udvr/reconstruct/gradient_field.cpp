#include "udvr/reconstruct/gradient_field.h"

#include <algorithm>
#include <cmath>

#include "udvr/reconstruct/gradient.h"
#include "udvr/util/check.h"
#include "udvr/util/parallel.h"

namespace udvr {

std::vector<float> gridGradients(const Grid3& grid, const float* values, int perVoxel, int first,
                                 int count, GradientLayout layout, const float* leading) {
    UDVR_CHECK(!leading || layout == GradientLayout::VoxelRows);
    UDVR_CHECK(layout != GradientLayout::ValueRows || count == 1);
    const CellGeometry g(grid);
    const GradientGeometry gg(grid);
    const std::size_t n = grid.pointCount();
    const std::size_t layers = static_cast<std::size_t>(count) + (leading ? 1 : 0);
    const bool valueRows = layout == GradientLayout::ValueRows;
    std::vector<float> out(n * (valueRows ? 4 : layers * 3));
    const std::size_t rows = static_cast<std::size_t>(grid.dims[1]) * grid.dims[2];
    parallelForChunks(rows, 16, [&](std::size_t rb, std::size_t re) {
        for (std::size_t row = rb; row < re; ++row) {
            const int j = static_cast<int>(row % grid.dims[1]);
            const int k = static_cast<int>(row / grid.dims[1]);
            for (int i = 0; i < grid.dims[0]; ++i) {
                const std::size_t v = grid.index(i, j, k);
                for (std::size_t l = 0; l < layers; ++l) {
                    const auto d = leading && l == 0
                                       ? gridGradient(g, gg, leading, 1, i, j, k)
                                       : gridGradient(g, gg, values + first + l - (leading ? 1 : 0),
                                                      perVoxel, i, j, k);
                    if (valueRows) out[v * 4] = values[v * perVoxel + first];
                    for (std::size_t a = 0; a < 3; ++a)
                        out[layout == GradientLayout::Planes ? (l * 3 + a) * n + v
                            : valueRows                      ? v * 4 + 1 + a
                                        : (v * 3 + a) * layers + l] = static_cast<float>(d[a]);
                }
            }
        }
    });
    return out;
}

const std::vector<float>& GradientCache::of(const Grid3& grid, const float* values, int perVoxel,
                                            int first, int count, GradientLayout layout,
                                            const float* leading) {
    // Least recently used first: a hit moves to the back (the vectors move, their data stay put),
    // so the array asked for last survives the next new one.
    for (auto it = entries_.begin(); it != entries_.end(); ++it)
        if (it->values == values && it->perVoxel == perVoxel && it->first == first &&
            it->count == count && it->layout == layout && it->leading == leading &&
            it->dims == grid.dims && it->spacing == grid.spacing) {
            std::rotate(it, it + 1, entries_.end());
            return entries_.back().gradients;
        }
    if (entries_.size() >= 2) entries_.erase(entries_.begin());
    entries_.push_back({values, perVoxel, first, count, layout, leading, grid.dims, grid.spacing,
                        gridGradients(grid, values, perVoxel, first, count, layout, leading)});
    return entries_.back().gradients;
}

std::vector<float> gridGradientMagnitudes(const Grid3& grid, const float* values) {
    const std::vector<float> d = gridGradients(grid, values, 1, 0, 1);
    const std::size_t n = grid.pointCount();
    std::vector<float> out(n);
    for (std::size_t v = 0; v < n; ++v)
        out[v] = std::sqrt(d[v] * d[v] + d[n + v] * d[n + v] + d[2 * n + v] * d[2 * n + v]);
    return out;
}

}  // namespace udvr
