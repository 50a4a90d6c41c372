#pragma once
// Internals shared by the io translation units; not part of the public API. The VTK code lives
// in vti_io.cpp and the NetCDF code in netcdf_io.cpp so their heavy headers stay there.
#include <array>
#include <cstddef>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "udvr/classify/transfer_function_2d.h"
#include "udvr/io/ensemble_io.h"
#include "udvr/io/file_info.h"
#include "udvr/stats/model_volume.h"
#include "udvr/util/field.h"

namespace udvr::detail {

/// Throw a UdvrError naming `path` if any value is NaN or Inf: how many of each and the first
/// voxel (i,j,k). `components` values per voxel; `what` names the array or member ("" = none).
void checkFinite(const std::filesystem::path& path, const Grid3& grid,
                 std::span<const float> values, int components = 1, const std::string& what = "");

/// A model file whose arrays hold what no model may (NaN, a negative stddev, decreasing
/// quantiles; checkModelArrays): readModelOrField says so instead of reading the file as a plain
/// field (which misled as "a plain field, not a model", issue 34).
class ModelContentError : public UdvrError {
  public:
    using UdvrError::UdvrError;
};

/// Throw a UdvrError unless `path` names an existing regular file.
void requireFile(const std::filesystem::path& path);

/// dims[0] × dims[1] × dims[2] × valueSize bytes; throws a UdvrError naming `path` where that
/// is more than any file udvr reads can hold (2^56 bytes; the product cannot overflow then).
std::size_t checkedDataBytes(const std::filesystem::path& path, const std::array<int, 3>& dims,
                             std::size_t valueSize);

/// The whole file as bytes (requireFile first); a UdvrError naming it when it cannot be read.
std::string readWholeFile(const std::filesystem::path& path);
/// `actual` bytes of data must be exactly `expected` (what the dims and type ask for): else a
/// UdvrError naming the file, "truncated <what>" or "dims do not match the <what> size".
void requireByteCount(const std::filesystem::path& path, std::size_t expected, std::size_t actual,
                      const std::string& what);

/// Whether an input names a glob pattern (has * ? or [); one that is itself a file is read as one.
bool isGlobPattern(const std::string& s);
/// The files a glob pattern matches, in glob(3)'s order; a UdvrError when none.
std::vector<std::string> expandGlob(const std::string& pattern);

/// Lower-case extension with the dot (".nhdr").
std::string lowerExtension(const std::filesystem::path& path);

/// readField that hands back the one-line note about the geometry (missing NetCDF coordinates,
/// an orientation that is ignored) in *geometryNote (left alone when there is none; nullptr: no
/// note) instead of printing it, so that the caller prints it only after the whole read
/// succeeded (an error is one stderr line).
ScalarField readFieldImpl(const std::filesystem::path& path, const FieldReadOptions& options,
                          std::string* geometryNote);
/// Print a note on its own stderr line; nothing for an empty one.
void printNote(const std::string& note);

/// A headerless raw file in the given layout (raw_io.cpp), read whole / a slab at a time.
ScalarField readRaw(const std::filesystem::path& path, const RawLayout& layout);
SlabReader openRawSlabs(const std::filesystem::path& path, const RawLayout& layout);
/// A NRRD file (nrrd_io.cpp); *geometryNote as readFieldImpl (an orientation that is ignored).
ScalarField readNrrd(const std::filesystem::path& path, std::string* geometryNote);
/// .vti through VTK's XML reader (vti_io.cpp); *geometryNote as readFieldImpl.
ScalarField readFieldVti(const std::filesystem::path& path, const std::string& var,
                         std::string* geometryNote);
/// readModelVti with its note as readFieldImpl's.
ModelVolume readModelVti(const std::filesystem::path& path, std::string* geometryNote);
/// A 2D transfer-function raster from a .vti of W×H×1 points (vti_io.cpp).
TransferFunction2D readTransferFunction2DVti(const std::filesystem::path& path);
/// How long the child process that tries a NetCDF-4 file's HDF5 calls first may take for a
/// file of 0 bytes (plus 1 s per 4 MB): 10 s unless set (the fuzz targets and tests set less,
/// so that a damaged file costs little).
void setHdf5ProbeSeconds(double seconds);
/// .nc with a 3D variable (netcdf_io.cpp); allowMissing: fill values become NaN.
ScalarField readFieldNetcdf(const std::filesystem::path& path, const std::string& var,
                            std::string* geometryNote, bool allowMissing = false);
/// .nc with a member dimension (netcdf_io.cpp).
Ensemble readEnsembleNetcdf(const std::filesystem::path& path, const EnsembleReadOptions& options);
/// A 3D NetCDF variable as readFieldNetcdf finds it / a member-dimension variable as
/// readEnsembleNetcdf finds it, read as hyperslabs (netcdf_io.cpp).
SlabReader openFieldNetcdfSlabs(const std::filesystem::path& path, const std::string& var,
                                bool allowMissing);
SlabReader openEnsembleNetcdfSlabs(const std::filesystem::path& path,
                                   const EnsembleReadOptions& options);
/// Size `e.values` for e.members × e.grid in options' layout, after options.checkSize
/// (ensemble_io.cpp).
void allocateEnsemble(Ensemble& e, const EnsembleReadOptions& options);
/// Store member m's values in e's layout (member-major or voxel-major).
void storeMember(Ensemble& e, int m, std::span<const float> values);

/// The arrays of a .vti's point data (vti_io.cpp) and the numeric variables of a .nc
/// (netcdf_io.cpp), for listArrays.
std::vector<ArrayInfo> listArraysVti(const std::filesystem::path& path);
std::vector<ArrayInfo> listArraysNetcdf(const std::filesystem::path& path);
/// The value type of a NRRD file as uint8 … float64 (nrrd_io.cpp).
std::string nrrdTypeName(const std::filesystem::path& path);

}  // namespace udvr::detail
