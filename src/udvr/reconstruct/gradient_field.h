#pragma once
// Grid gradients of whole arrays (SPEC §9), computed once per model and kept beside it: the
// kernels then blend a sample's gradient trilinearly from the 8 corners like any per-voxel value.
#include <array>
#include <cstddef>
#include <vector>

#include "udvr/util/grid.h"

namespace udvr {

/// How gridGradients lays out its output for N voxels and `count` layers.
enum class GradientLayout {
    /// One plane of N floats per layer and axis: out[(l·3 + axis)·N + v] (each plane blends like
    /// a one-float field, with 64-bit pair gathers on the lanes).
    Planes,
    /// One row of 3·count floats per voxel, the layers' x components, then y, then z:
    /// out[v·3·count + axis·count + l] (a batch reads a corner's row with one or two loads and
    /// blends all of them at once, as the quantile boundaries, boundaryRows).
    VoxelRows,
};

/// Grid gradients (world units) of layers first … first + count − 1 of a voxel-major array with
/// perVoxel floats per voxel.
std::vector<float> gridGradients(const Grid3& grid, const float* values, int perVoxel, int first,
                                 int count, GradientLayout layout = GradientLayout::Planes);

/// Grid gradients kept between frames (gridGradients of the same arrays are reused): keyed by
/// the array's address, layout and grid, so a model edited in place needs clear(). Holds the
/// last two arrays asked for (the mean and a model's boundaries).
class GradientCache {
  public:
    /// gridGradients(grid, values, perVoxel, first, count, layout), computed on first use. Its
    /// data() stays valid until two other arrays have been asked for since, or clear().
    const std::vector<float>& of(const Grid3& grid, const float* values, int perVoxel, int first,
                                 int count, GradientLayout layout = GradientLayout::Planes);
    void clear() { entries_.clear(); }

  private:
    struct Entry {
        const float* values;
        int perVoxel, first, count;
        GradientLayout layout;
        std::array<int, 3> dims;
        std::array<double, 3> spacing;
        std::vector<float> gradients;
    };
    std::vector<Entry> entries_;
};

/// |∇f| at every grid point of a one-float-per-voxel array (for joint histograms).
std::vector<float> gridGradientMagnitudes(const Grid3& grid, const float* values);

}  // namespace udvr
