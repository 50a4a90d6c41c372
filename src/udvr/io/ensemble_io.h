#pragma once
// Ensemble readers and writers (SPEC §7): one NetCDF variable with a member dimension, or a
// list (or glob) of member files of any field format, all on the same grid.
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "udvr/io/field.h"
#include "udvr/io/field_io.h"

namespace udvr {

struct EnsembleReadOptions {
    std::string var;        // NetCDF variable; empty = the only variable with a member dimension
    std::string memberDim;  // empty = member/ensemble/realization/number (first found)
    RawLayout raw;          // for raw member files
    /// Let NaN/Inf through, and read NetCDF fill values as NaN (`build --nan skip`).
    bool allowMissing = false;
    /// Store the values voxel-major (Ensemble::voxelMajor: a voxel's members contiguous, the
    /// `members` kernel's layout) instead of member-major; costs one member of scratch.
    bool voxelMajor = false;
    /// Called with the member count and grid once they are known and before the values are
    /// allocated (e.g. a memory cap); may throw.
    std::function<void(int members, const Grid3& grid)> checkSize;
};

/// inputs: one .nc file with a member dimension, or ≥2 member files, or glob patterns ('m_*.nhdr').
/// Throws UdvrError for fewer than 2 members, mismatched grids, missing files or non-finite values.
Ensemble readEnsemble(const std::vector<std::string>& inputs, const EnsembleReadOptions& options);

/// Write NetCDF: variable `ensemble.name` (or "value") with dims (member, z, y, x) and CF
/// coordinate variables x, y, z; atomically.
void writeEnsembleNetcdf(const std::filesystem::path& path, const Ensemble& ensemble);

}  // namespace udvr
