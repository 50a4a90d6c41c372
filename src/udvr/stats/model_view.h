#pragma once
// A model's arrays by pointer: what the renderer and classification read. A view of a
// ModelVolume (made implicitly where a function taking a view gets a ModelVolume) or of arrays
// held elsewhere — ParaView's VTK arrays, which the plugin renders without copying them.
#include <array>
#include <cstddef>
#include <span>
#include <string>

#include "udvr/stats/model_volume.h"
#include "udvr/util/grid.h"

namespace udvr {

/// Lifetime contract: a view owns nothing. Whoever makes one keeps the arrays it points to
/// alive and unchanged while any call given the view runs; a RenderCache that rendered a view
/// (keyed by the arrays' addresses) is cleared before the arrays are freed or refilled, as
/// freed memory may come back at the same address. Functions taking a view keep no reference
/// to it after they return.
struct ModelView {
    Grid3 grid;
    std::span<const float> mean, stddev, min, max;  // 1 float per voxel each (empty: absent)
    int quantileCount = 0;
    std::span<const float> quantiles;        // q + 1 per voxel
    std::span<const float> iqr;              // 2 per voxel
    std::span<const double> quantileLevels;  // empty: even levels
    int gmmComponents = 0;
    std::span<const float> gmm;  // 3K per voxel
    int memberCount = 0;
    std::span<const float> members;  // n per voxel
    int samplesPerVoxel = 0;
    std::array<double, 6> bounds{};  // full-resolution world bounds (all 0: the grid's box)
    double fullResMinSpacing = 1.0;

    ModelView() = default;
    /// The arrays and field data of `m`, which must outlive the view.
    ModelView(const ModelVolume& m)  // NOLINT(google-explicit-constructor): used implicitly
        : grid(m.grid),
          mean(m.mean),
          stddev(m.stddev),
          min(m.min),
          max(m.max),
          quantileCount(m.quantileCount),
          quantiles(m.quantiles),
          iqr(m.iqr),
          quantileLevels(m.quantileLevels),
          gmmComponents(m.gmmComponents),
          gmm(m.gmm),
          memberCount(m.memberCount),
          members(m.members),
          samplesPerVoxel(m.samplesPerVoxel),
          bounds(m.bounds),
          fullResMinSpacing(m.fullResMinSpacing) {}

    std::size_t voxelCount() const { return grid.pointCount(); }
    bool hasQuantiles() const { return quantileCount > 0 && !quantiles.empty(); }
    bool hasGmm() const { return gmmComponents > 0 && !gmm.empty(); }
    /// t_j of boundary j (j/q for even levels).
    double quantileLevel(int j) const {
        return quantileLevels.empty() ? static_cast<double>(j) / quantileCount
                                      : quantileLevels[static_cast<std::size_t>(j)];
    }
    /// The boundary j at level t (within 1e−9), or −1 where no boundary sits there.
    int boundaryAtLevel(double t) const;
    /// The levels for the kernels: null for even levels.
    const double* levelsOrNull() const {
        return quantileLevels.empty() ? nullptr : quantileLevels.data();
    }
    const float* quantilesAt(std::size_t v) const {
        return quantiles.data() + v * static_cast<std::size_t>(quantileCount + 1);
    }
    const float* gmmAt(std::size_t v) const {
        return gmm.data() + v * static_cast<std::size_t>(3 * gmmComponents);
    }
    /// The view's array of a model file array (kModelFileArrays): mean, …, gmm.
    std::span<const float>& array(const ModelFileArray& a);
    std::span<const float> array(const ModelFileArray& a) const {
        return const_cast<ModelView*>(this)->array(a);
    }
};

/// checkModelArrays (model_volume.h) over a view: the same checks and messages.
void checkModelArrays(const ModelView& m, const std::string& what);

}  // namespace udvr
