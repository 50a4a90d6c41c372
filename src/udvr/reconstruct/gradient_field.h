#pragma once
// Grid gradients of whole arrays (SPEC §9), computed once per model and kept beside it: the
// kernels then blend a sample's gradient trilinearly from the 8 corners like any per-voxel value.
#include <cstddef>
#include <vector>

#include "udvr/util/grid.h"

namespace udvr {

/// Grid gradients (world units) of layers first … first + count − 1 of a voxel-major array with
/// perVoxel floats per voxel: out[(v·count + l)·3 + axis] for voxel v and layer l.
std::vector<float> gridGradients(const Grid3& grid, const float* values, int perVoxel, int first,
                                 int count);

/// |∇f| at every grid point of a one-float-per-voxel array (for joint histograms).
std::vector<float> gridGradientMagnitudes(const Grid3& grid, const float* values);

}  // namespace udvr
