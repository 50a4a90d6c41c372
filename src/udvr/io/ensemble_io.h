#pragma once
// Ensemble readers and writers (SPEC §7): one NetCDF variable with a member dimension, or a
// list (or glob) of member files of any field format, all on the same grid.
#include <filesystem>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "udvr/io/field_io.h"
#include "udvr/util/field.h"

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

/// An ensemble, or one field (members = 1), read a slab of whole z-planes at a time (the
/// out-of-core `build`). NetCDF variables are read as hyperslabs (nc_get_vara) and raw files at
/// an offset; VTI and NRRD members are read whole for every slab (VTK's reader and gzip do not
/// read part of a file) and the slab's planes kept. Values are not checked for NaN/Inf (build's
/// own scan does); NetCDF fill values are an error unless allowMissing (then NaN).
struct SlabReader {
    Grid3 grid;
    int members = 0;
    std::string name;
    double valueStep = 0.0;   // as Ensemble's
    std::string valueType{};  // as Ensemble's
    /// Planes [z0, z1) of every member, member-major: member m at out[m·(z1 − z0)·X·Y …].
    std::function<void(int z0, int z1, std::span<float> out)> read;
    std::size_t scratchPerPlane = 0;  // bytes a read holds besides `out`, per z-plane
    std::size_t scratchFixed = 0;     // bytes a read holds whatever the slab (a member read whole)
    bool wholeMembers = false;        // some members are read whole for every slab
    std::string note;                 // the geometry note, for the caller to print
};

/// The inputs of readEnsemble as a SlabReader; the same errors about files, grids and members.
SlabReader openEnsembleSlabs(const std::vector<std::string>& inputs,
                             const EnsembleReadOptions& options);
/// One field (readField's formats) as a SlabReader of one member.
SlabReader openFieldSlabs(const std::filesystem::path& path, const FieldReadOptions& options);

/// Write NetCDF: variable `ensemble.name` (or "value") with dims (member, z, y, x) and CF
/// coordinate variables x, y, z; atomically.
void writeEnsembleNetcdf(const std::filesystem::path& path, const Ensemble& ensemble);

}  // namespace udvr
