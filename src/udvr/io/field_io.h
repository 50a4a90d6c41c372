#pragma once
// Scalar-field readers and writers (SPEC §7): raw, NRRD (.nrrd/.nhdr), VTK XML ImageData
// (.vti), NetCDF (.nc). Every reader rejects truncated files, dims that do not match the data
// and non-finite values with a UdvrError that names the file.
#include <array>
#include <filesystem>
#include <span>
#include <string>
#include <utility>

#include "udvr/util/check.h"
#include "udvr/util/field.h"

namespace udvr {

/// Layout of a headerless raw file, given on the command line.
struct RawLayout {
    std::array<int, 3> dims{0, 0, 0};  // all > 0 when given
    std::string type = "float32";      // uint8 int8 uint16 int16 uint32 int32 float32 float64
    bool bigEndian = false;
    std::array<double, 3> spacing{1.0, 1.0, 1.0};
    std::array<double, 3> origin{0.0, 0.0, 0.0};
    bool given() const { return dims[0] > 0 && dims[1] > 0 && dims[2] > 0; }
};

struct FieldReadOptions {
    RawLayout raw;    // required for .raw files
    std::string var;  // array (.vti) or variable (.nc) name; empty = the only/first scalar one
    /// Let NaN/Inf through, and read NetCDF fill values as NaN, instead of refusing them
    /// (`build --nan skip` leaves them out of each voxel's samples).
    bool allowMissing = false;
};

/// readField's error for a NetCDF file that holds an ensemble (a variable with a member
/// dimension of 2 or more) rather than one field. what() says so and names `udvr build`; the
/// members let a command say what to do instead.
class EnsembleNotFieldError : public UdvrError {
  public:
    EnsembleNotFieldError(const std::string& message, std::string file_, std::string var_,
                          std::string dims_, int members_)
        : UdvrError(message),
          file(std::move(file_)),
          var(std::move(var_)),
          dims(std::move(dims_)),
          members(members_) {}
    std::string file, var, dims;  // dims as in the file, slowest first: "member,z,y,x"
    int members = 0;
};

/// Read one scalar field; the format is chosen by extension (.raw .nrrd .nhdr .vti .nc).
ScalarField readField(const std::filesystem::path& path, const FieldReadOptions& options = {});

/// The one file a quoted glob names where one field or model is read (render, probe, info,
/// build --downsample, Python's load): a path that exists, or is no pattern (* ? [), as given;
/// else the pattern's one match. A UdvrError when it matches no file or several (naming the
/// first two and saying that an ensemble is built or rendered with --model members).
std::filesystem::path singleFileOf(const std::filesystem::path& path);
/// The inputs of a command that takes one field or an ensemble (build, info): one quoted glob
/// that matches exactly one file becomes that file (so it is read as one field); anything else
/// is returned as given.
std::vector<std::string> withOneMatchResolved(const std::vector<std::string>& inputs);

/// Write a field as VTK XML ImageData (point array named field.name or "scalars"), atomically.
void writeFieldVti(const std::filesystem::path& path, const ScalarField& field);
/// Write a field as NetCDF with dims z,y,x and CF coordinate variables x,y,z, atomically.
void writeFieldNetcdf(const std::filesystem::path& path, const ScalarField& field);
/// Write by extension (.vti or .nc).
void writeField(const std::filesystem::path& path, const ScalarField& field);

/// Origin and spacing of an axis from its grid points' positions (CF coordinate values, SPEC §7):
/// finite, increasing, evenly spaced within float rounding (1e-4 of a step + 1e-6 of the
/// magnitude); one point: spacing 1. `what` names the axis in errors ("f.nc: coordinate
/// variable x"). Throws UdvrError otherwise.
std::pair<double, double> regularAxis(std::span<const double> coords, const std::string& what);

}  // namespace udvr
