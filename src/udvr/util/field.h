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
    /// The spacing of the values the file's type can hold, data units (the step that
    /// `--density dequantized` spreads each value over): 1 for integer types, |scale_factor|
    /// for CF-packed integers; 0 for floating-point types and fields made in memory.
    double valueStep = 0.0;
    std::string valueType{};  // the file's value type (uint8 … float64); "" when made in memory
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
    double valueStep = 0.0;   // as ScalarField::valueStep; 0 unless every member has the same step
    std::string valueType{};  // as ScalarField::valueType; "mixed" when the members differ

    const float* member(int m) const {
        return values.data() + static_cast<std::size_t>(m) * grid.pointCount();
    }
    float* member(int m) { return values.data() + static_cast<std::size_t>(m) * grid.pointCount(); }
};

}  // namespace udvr
