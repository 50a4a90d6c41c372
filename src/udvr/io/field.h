#pragma once
// In-memory scalar fields and ensembles. Values are float32 whatever the file type was.
#include <string>
#include <vector>

#include "udvr/util/grid.h"

namespace udvr {

/// One scalar value per grid point, x fastest (SPEC §1).
struct ScalarField {
    Grid3 grid;
    std::vector<float> values;  // grid.pointCount() values
    std::string name;           // array/variable name where the file had one
};

/// n members on one grid. Member-major: values[m * pointCount + p] (each member contiguous);
/// voxel-major where `voxelMajor` (EnsembleReadOptions::voxelMajor): values[p * members + m],
/// and member() does not apply.
struct Ensemble {
    Grid3 grid;
    int members = 0;
    std::vector<float> values;  // members * grid.pointCount()
    std::string name;
    bool voxelMajor = false;

    const float* member(int m) const {
        return values.data() + static_cast<std::size_t>(m) * grid.pointCount();
    }
    float* member(int m) { return values.data() + static_cast<std::size_t>(m) * grid.pointCount(); }
};

}  // namespace udvr
