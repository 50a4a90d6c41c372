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
    /// One row of 3·L floats per voxel for L layers, the layers' x components, then y, then z:
    /// out[v·3·L + axis·L + l] (a batch reads a corner's row with a few loads and blends all of
    /// them at once, as the quantile boundaries, boundaryRows).
    VoxelRows,
    /// One row of 4 floats per voxel for one layer (count = 1): the layer's value, then its
    /// gradient's x, y, z components: out[v·4 + 0] = value, out[v·4 + 1 + axis] (the 2D
    /// mean-field kernel reads a corner's value and gradient with one load, rows4).
    ValueRows,
};

/// Grid gradients (world units) of layers first … first + count − 1 of a voxel-major array with
/// perVoxel floats per voxel. With `leading` (a one-float-per-voxel array, VoxelRows only), its
/// gradient is layer 0 and the array's layers follow (L = count + 1): the 2D quantile kernels
/// blend the mean's gradient with the boundaries' from one row.
std::vector<float> gridGradients(const Grid3& grid, const float* values, int perVoxel, int first,
                                 int count, GradientLayout layout = GradientLayout::Planes,
                                 const float* leading = nullptr);

/// Grid gradients kept between frames (gridGradients of the same arrays are reused): keyed by
/// the array's address, layout and grid, so a model edited in place needs clear() (ValueRows
/// also copy the values). Holds the last two arrays asked for: a 2D kernel asks for one (the
/// mean's value rows or planes, or a quantile model's boundary rows with the mean leading), so a
/// session switching between two models keeps both.
class GradientCache {
  public:
    /// gridGradients(grid, values, perVoxel, first, count, layout, leading), computed on first
    /// use. Its data() stays valid until two other arrays have been asked for since, or clear().
    const std::vector<float>& of(const Grid3& grid, const float* values, int perVoxel, int first,
                                 int count, GradientLayout layout = GradientLayout::Planes,
                                 const float* leading = nullptr);
    void clear() { entries_.clear(); }

  private:
    struct Entry {
        const float* values;
        int perVoxel, first, count;
        GradientLayout layout;
        const float* leading;
        std::array<int, 3> dims;
        std::array<double, 3> spacing;
        std::vector<float> gradients;
    };
    std::vector<Entry> entries_;
};

/// |∇f| at every grid point of a one-float-per-voxel array (for joint histograms).
std::vector<float> gridGradientMagnitudes(const Grid3& grid, const float* values);

}  // namespace udvr
