// NetCDF fields and ensembles (SPEC §7) through the netCDF-C library. Geometry travels as CF
// coordinate variables x, y, z (grid point positions, evenly spaced).
#include <fcntl.h>
#include <hdf5.h>
#ifdef UDVR_FUZZ_LIBFUZZER
#include <sanitizer/common_interface_defs.h>
#endif
#include <netcdf.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <iomanip>
#include <limits>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "udvr/io/ensemble_io.h"
#include "udvr/io/field_io.h"
#include "udvr/io/io_detail.h"
#include "udvr/io/netcdf_access.h"
#include "udvr/util/atomic_file.h"
#include "udvr/util/check.h"

namespace udvr {
namespace fs = std::filesystem;
using namespace netcdf;

namespace {
constexpr const char* kMemberDimNames[] = {"member", "ensemble", "realization", "number"};

struct VarInfo {
    int id = -1;
    std::string name;
    std::vector<int> dims;
    std::vector<std::size_t> lengths;
    std::vector<std::string> dimNames;
};

VarInfo varInfo(const fs::path& path, int nc, int varid) {
    VarInfo v;
    v.id = varid;
    char name[NC_MAX_NAME + 1];
    int ndims = 0;
    ncCheck(nc_inq_varname(nc, varid, name), path, "variable name");
    v.name = name;
    ncCheck(nc_inq_varndims(nc, varid, &ndims), path, "variable dims");
    v.dims.resize(static_cast<std::size_t>(ndims));
    if (ndims > 0) ncCheck(nc_inq_vardimid(nc, varid, v.dims.data()), path, "variable dims");
    for (int d : v.dims) {
        std::size_t len = 0;
        ncCheck(nc_inq_dim(nc, d, name, &len), path, "dimension");
        v.lengths.push_back(len);
        v.dimNames.push_back(name);
    }
    return v;
}

std::vector<VarInfo> allVars(const fs::path& path, int nc) {
    int nvars = 0;
    ncCheck(nc_inq_nvars(nc, &nvars), path, "variables");
    std::vector<VarInfo> vars;
    for (int i = 0; i < nvars; ++i) vars.push_back(varInfo(path, nc, i));
    return vars;
}

bool isNumeric(int nc, int varid) {
    nc_type t;
    if (nc_inq_vartype(nc, varid, &t) != NC_NOERR) return false;
    return t == NC_BYTE || t == NC_UBYTE || t == NC_SHORT || t == NC_USHORT || t == NC_INT ||
           t == NC_UINT || t == NC_INT64 || t == NC_UINT64 || t == NC_FLOAT || t == NC_DOUBLE;
}

bool isCoordinateVar(const VarInfo& v) { return v.dims.size() == 1 && v.dimNames[0] == v.name; }

std::string describe(const VarInfo& v) {
    std::string s = v.name + "(";
    for (std::size_t d = 0; d < v.dims.size(); ++d) {
        s += (d ? "," : "") + v.dimNames[d] + "=" + std::to_string(v.lengths[d]);
    }
    return s + ")";
}

/// Fail with EnsembleNotFieldError when `v` is an ensemble: 4 numeric dims, one of them a
/// member dimension of 2 or more (a field was asked for).
void failIfEnsemble(const fs::path& path, int nc, const VarInfo& v) {
    if (v.dims.size() != 4 || !isNumeric(nc, v.id)) return;
    for (std::size_t d = 0; d < 4; ++d) {
        if (std::find(std::begin(kMemberDimNames), std::end(kMemberDimNames), v.dimNames[d]) ==
                std::end(kMemberDimNames) ||
            v.lengths[d] < 2)
            continue;
        std::string dims;
        for (const std::string& n : v.dimNames) dims += (dims.empty() ? "" : ",") + n;
        const int members = static_cast<int>(std::min<std::size_t>(v.lengths[d], INT32_MAX));
        std::ostringstream os;
        os << path.string() << " holds a " << members << "-member ensemble (variable '" << v.name
           << "', dims " << dims << "), not one field; 'udvr build " << path.string()
           << " -o model.vti' builds a model from its members";
        throw EnsembleNotFieldError(os.str(), path.string(), v.name, dims, members);
    }
}

std::string describeAll(const std::vector<VarInfo>& vars) {
    std::string s;
    for (const auto& v : vars) s += (s.empty() ? "" : ", ") + describe(v);
    return s.empty() ? "none" : s;
}

/// Geometry from the CF coordinate variables of the last three dims (z, y, x order in the file).
/// Absent ones give origin 0, spacing 1 and a one-line note in *note (when given), which the
/// caller prints once the whole read has succeeded; an uneven axis is an error.
Grid3 gridFromCoordinates(const fs::path& path, int nc, const VarInfo& var, std::size_t first,
                          std::string* note) {
    Grid3 g;
    std::string missing;
    for (int a = 0; a < 3; ++a) {
        std::size_t d = first + static_cast<std::size_t>(2 - a);  // x is the fastest (last) dim
        std::size_t len = var.lengths[d];
        const std::string& dimName = var.dimNames[d];
        if (len == 0 || len > static_cast<std::size_t>(INT32_MAX))
            UDVR_FAIL(path.string()
                      << ": dimension " << dimName << " of variable " << var.name << " has length "
                      << len << " (expected 1 to " << INT32_MAX << ")");
        g.dims[a] = static_cast<int>(len);
        int cid = -1;
        int ndims = 0, cdim = -1;
        if (nc_inq_varid(nc, dimName.c_str(), &cid) != NC_NOERR ||
            nc_inq_varndims(nc, cid, &ndims) != NC_NOERR || ndims != 1 ||
            nc_inq_vardimid(nc, cid, &cdim) != NC_NOERR || cdim != var.dims[d]) {
            missing += (missing.empty() ? "" : ", ") + dimName;
            continue;
        }
        std::vector<double> c(len);
        ncCheck(nc_get_var_double(nc, cid, c.data()), path, "coordinate variable " + dimName);
        std::tie(g.origin[a], g.spacing[a]) =
            regularAxis(c, path.string() + ": coordinate variable " + dimName);
    }
    detail::checkedDataBytes(path, g.dims, sizeof(float));
    if (!missing.empty() && note != nullptr) {
        *note = "udvr: note: " + path.string() + " has no coordinate variables for " + missing +
                "; using origin 0 and spacing 1 there";
    }
    return g;
}

/// CF packing (scale_factor, add_offset) and fill values of a variable.
struct Packing {
    double scale = 1.0, offset = 0.0;
    std::vector<double> fills;  // _FillValue, missing_value
};

Packing packingOf(int nc, int varid) {
    Packing p;
    auto attr = [&](const char* name, std::vector<double>& out) {
        std::size_t len = 0;
        nc_type t;
        if (nc_inq_att(nc, varid, name, &t, &len) != NC_NOERR || len == 0 || t == NC_CHAR ||
            t == NC_STRING) {
            return;
        }
        std::vector<double> v(len);
        if (nc_get_att_double(nc, varid, name, v.data()) == NC_NOERR) {
            out.insert(out.end(), v.begin(), v.end());
        }
    };
    std::vector<double> scale, offset;
    attr("scale_factor", scale);
    attr("add_offset", offset);
    attr("_FillValue", p.fills);
    attr("missing_value", p.fills);
    if (!scale.empty()) p.scale = scale[0];
    if (!offset.empty()) p.offset = offset[0];
    return p;
}

/// A numeric variable's type as int8 … float64 (ArrayInfo::type, ScalarField::valueType).
std::string valueTypeOf(const fs::path& path, int nc, int varid) {
    nc_type t;
    ncCheck(nc_inq_vartype(nc, varid, &t), path, "variable type");
    switch (t) {
        case NC_BYTE:
            return "int8";
        case NC_UBYTE:
            return "uint8";
        case NC_SHORT:
            return "int16";
        case NC_USHORT:
            return "uint16";
        case NC_INT:
            return "int32";
        case NC_UINT:
            return "uint32";
        case NC_INT64:
            return "int64";
        case NC_UINT64:
            return "uint64";
        case NC_FLOAT:
            return "float32";
        default:
            return "float64";
    }
}

/// ScalarField::valueStep of a variable of type `type`: 1 for integers, |scale_factor| for
/// CF-packed integers (the spacing of the unpacked values), 0 for floating-point types.
double valueStepOf(int nc, int varid, const std::string& type) {
    if (type == "float32" || type == "float64") return 0.0;
    return std::abs(packingOf(nc, varid).scale);
}

/// Read `count` values of a hyperslab, rejecting fill values (or with fillsAsNaN reading them as
/// NaN) and applying CF packing.
void readSlab(const fs::path& path, int nc, const VarInfo& var, const std::vector<size_t>& start,
              const std::vector<size_t>& count, std::span<float> out, const std::string& what,
              bool fillsAsNaN = false) {
    Packing p = packingOf(nc, var.id);
    bool raw = p.scale == 1.0 && p.offset == 0.0 && p.fills.empty();
    if (raw) {
        int status = nc_get_vara_float(nc, var.id, start.data(), count.data(), out.data());
        if (status != NC_ERANGE) {
            ncCheck(status, path, "reading variable " + var.name + what);
            return;
        }
        // NC_ERANGE: Inf (reported by the caller with its position) or finite values too large
        // for float32.
    }
    std::vector<double> v(out.size());
    ncCheck(nc_get_vara_double(nc, var.id, start.data(), count.data(), v.data()), path,
            "reading variable " + var.name + what);
    std::size_t filled = 0, firstFilled = 0, tooLarge = 0;
    for (std::size_t i = 0; i < v.size(); ++i) {
        double scaled = v[i] * p.scale + p.offset;
        if (std::isfinite(scaled) && std::abs(scaled) > std::numeric_limits<float>::max()) {
            ++tooLarge;
        }
        if (std::find(p.fills.begin(), p.fills.end(), v[i]) != p.fills.end()) {
            if (filled++ == 0) firstFilled = i;
            if (fillsAsNaN) scaled = std::numeric_limits<double>::quiet_NaN();
        }
        out[i] = static_cast<float>(scaled);
    }
    if (tooLarge > 0) {
        UDVR_FAIL(path.string() << ": variable " << var.name << what << " has " << tooLarge
                                << " values outside the float32 range");
    }
    if (filled > 0 && !fillsAsNaN) {
        UDVR_FAIL(path.string() << ": variable " << var.name << what << " has " << filled
                                << " missing (fill) values, the first at linear index "
                                << firstFilled << "; expected a complete field");
    }
}

/// Leading dims of length 1 (e.g. a single time step) are allowed before z, y, x.
bool isGridded(const VarInfo& v, std::size_t extraDims) {
    if (v.dims.size() < 3 + extraDims) return false;
    for (std::size_t d = extraDims; d + 3 < v.dims.size(); ++d) {
        if (v.lengths[d] != 1) return false;
    }
    return true;
}

std::string safeName(const std::string& name, const char* fallback) {
    std::string s = name.empty() ? fallback : name;
    for (char& c : s) {
        if (c == '/' || static_cast<unsigned char>(c) < 32) c = '_';
    }
    if (s == "x" || s == "y" || s == "z" || s == "member") s += "_value";
    return s;
}

/// Define dims (member,) z, y, x, the coordinate variables and the data variable; write the
/// coordinates. Returns the data variable's id.
int defineGrid(const fs::path& path, int nc, const Grid3& grid, const std::string& varName,
               int members) {
    std::vector<int> dimIds;
    auto defDim = [&](const char* name, std::size_t len) {
        int id = -1;
        ncWriteCheck(nc_def_dim(nc, name, len, &id), path,
                     std::string("defining dimension ") + name);
        return id;
    };
    if (members > 0) dimIds.push_back(defDim("member", static_cast<std::size_t>(members)));
    const char* axisNames[3] = {"x", "y", "z"};
    const char* axisAttr[3] = {"X", "Y", "Z"};
    int axisDims[3];
    for (int a = 2; a >= 0; --a) {
        axisDims[a] = defDim(axisNames[a], static_cast<std::size_t>(grid.dims[a]));
        dimIds.push_back(axisDims[a]);
    }
    int coordIds[3];
    for (int a = 0; a < 3; ++a) {
        ncWriteCheck(nc_def_var(nc, axisNames[a], NC_DOUBLE, 1, &axisDims[a], &coordIds[a]), path,
                     "defining coordinate variable");
        ncWriteCheck(nc_put_att_text(nc, coordIds[a], "axis", 1, axisAttr[a]), path, "attribute");
        std::string longName = std::string(axisNames[a]) + " position of the grid points";
        ncWriteCheck(
            nc_put_att_text(nc, coordIds[a], "long_name", longName.size(), longName.c_str()), path,
            "attribute");
    }
    int varId = -1;
    ncWriteCheck(nc_def_var(nc, varName.c_str(), NC_FLOAT, static_cast<int>(dimIds.size()),
                            dimIds.data(), &varId),
                 path, "defining variable " + varName);
    const std::string conventions = "CF-1.8";
    ncWriteCheck(
        nc_put_att_text(nc, NC_GLOBAL, "Conventions", conventions.size(), conventions.c_str()),
        path, "attribute");
    const std::string source = "udvr";
    ncWriteCheck(nc_put_att_text(nc, NC_GLOBAL, "source", source.size(), source.c_str()), path,
                 "attribute");
    ncWriteCheck(nc_enddef(nc), path, "writing header");
    for (int a = 0; a < 3; ++a) {
        std::vector<double> c(static_cast<std::size_t>(grid.dims[a]));
        for (std::size_t i = 0; i < c.size(); ++i) {
            c[i] = grid.world(a, static_cast<double>(i));
        }
        ncWriteCheck(nc_put_var_double(nc, coordIds[a], c.data()), path, "writing coordinates");
    }
    return varId;
}

/// Classic 64-bit-offset format: readable by every NetCDF tool, no HDF5 needed.
void writeNetcdf(const fs::path& path, const Grid3& grid, const std::string& name, int members,
                 const std::vector<float>& values) {
    writeAtomically(path, [&](const fs::path& tmp) {
        NcFile file;
        ncWriteCheck(nc_create(tmp.c_str(), NC_CLOBBER | NC_64BIT_OFFSET, &file.id), path,
                     "creating");
        int varId = defineGrid(path, file.id, grid, name, members);
        std::size_t n = grid.pointCount();
        int slabs = std::max(members, 1);
        for (int m = 0; m < slabs; ++m) {
            std::vector<std::size_t> start, count;
            if (members > 0) {
                start.push_back(static_cast<std::size_t>(m));
                count.push_back(1);
            }
            for (int a = 2; a >= 0; --a) {
                start.push_back(0);
                count.push_back(static_cast<std::size_t>(grid.dims[a]));
            }
            ncWriteCheck(nc_put_vara_float(file.id, varId, start.data(), count.data(),
                                           values.data() + static_cast<std::size_t>(m) * n),
                         path, "writing data");
        }
        ncWriteCheck(file.close(), path, "closing");
    });
}

}  // namespace

namespace {

/// The 3D variable readFieldNetcdf reads: `varName`, or the only gridded numeric one.
VarInfo findFieldVar(const fs::path& path, int nc, const std::string& varName) {
    std::vector<VarInfo> vars = allVars(path, nc);
    const VarInfo* var = nullptr;
    if (!varName.empty()) {
        for (const auto& v : vars) {
            if (v.name == varName) var = &v;
        }
        if (var == nullptr) {
            UDVR_FAIL(path.string() << ": no variable '" << varName
                                    << "' (variables: " << describeAll(vars) << ")");
        }
        if (!isGridded(*var, 0)) {
            failIfEnsemble(path, nc, *var);
            UDVR_FAIL(path.string()
                      << ": variable " << describe(*var) << " is not a 3D field with dims z,y,x"
                      << " (an ensemble? read it with 'build')");
        }
    } else {
        std::vector<const VarInfo*> candidates;
        for (const auto& v : vars) {
            if (isGridded(v, 0) && !isCoordinateVar(v) && isNumeric(nc, v.id)) {
                candidates.push_back(&v);
            }
        }
        if (candidates.empty()) {
            for (const auto& v : vars) failIfEnsemble(path, nc, v);
            UDVR_FAIL(path.string() << ": no 3D variable with dims z,y,x (variables: "
                                    << describeAll(vars) << ")");
        }
        if (candidates.size() > 1) {
            UDVR_FAIL(path.string() << ": several 3D variables (" << describeAll(vars)
                                    << "); choose one with --var");
        }
        var = candidates[0];
    }
    if (!isNumeric(nc, var->id)) {
        UDVR_FAIL(path.string() << ": variable " << var->name << " is not numeric");
    }
    return *var;
}

ScalarField readFieldNetcdfUnguarded(const fs::path& path, const std::string& varName,
                                     std::string* geometryNote, bool allowMissing) {
    NcFile file;
    file.id = openForRead(path);
    const VarInfo v = findFieldVar(path, file.id, varName);
    const VarInfo* var = &v;
    std::size_t first = var->dims.size() - 3;
    ScalarField f;
    f.grid = gridFromCoordinates(path, file.id, *var, first, geometryNote);
    f.name = var->name;
    f.values.resize(f.grid.pointCount());
    std::vector<std::size_t> start(var->dims.size(), 0), count(var->lengths);
    readSlab(path, file.id, *var, start, count, f.values, "", allowMissing);
    f.valueType = valueTypeOf(path, file.id, var->id);
    f.valueStep = valueStepOf(file.id, var->id, f.valueType);
    return f;
}

/// The ensemble variable readEnsembleNetcdf reads and the index of its member dimension.
std::pair<VarInfo, std::size_t> findEnsembleVar(const fs::path& path, int nc,
                                                const EnsembleReadOptions& options) {
    std::vector<VarInfo> vars = allVars(path, nc);
    // Index of the member dimension of v, or -1.
    auto memberDimOf = [&](const VarInfo& v) -> int {
        for (std::size_t d = 0; d < v.dims.size(); ++d) {
            const std::string& n = v.dimNames[d];
            bool named = options.memberDim.empty()
                             ? std::find(std::begin(kMemberDimNames), std::end(kMemberDimNames),
                                         n) != std::end(kMemberDimNames)
                             : n == options.memberDim;
            if (named) return static_cast<int>(d);
        }
        return -1;
    };
    auto usable = [&](const VarInfo& v) {
        return v.dims.size() == 4 && memberDimOf(v) >= 0 && isNumeric(nc, v.id);
    };
    const VarInfo* var = nullptr;
    if (!options.var.empty()) {
        for (const auto& v : vars) {
            if (v.name == options.var) var = &v;
        }
        if (var == nullptr) {
            UDVR_FAIL(path.string() << ": no variable '" << options.var
                                    << "' (variables: " << describeAll(vars) << ")");
        }
        if (!usable(*var)) {
            UDVR_FAIL(path.string()
                      << ": variable " << describe(*var)
                      << " does not have 4 dims with a member dimension ("
                      << (options.memberDim.empty() ? "member, ensemble, realization or number"
                                                    : options.memberDim)
                      << ")");
        }
    } else {
        std::vector<const VarInfo*> candidates;
        for (const auto& v : vars) {
            if (usable(v)) candidates.push_back(&v);
        }
        if (candidates.empty()) {
            UDVR_FAIL(path.string()
                      << ": no variable with a member dimension ("
                      << (options.memberDim.empty() ? "member, ensemble, realization or number"
                                                    : options.memberDim)
                      << ") and 3 grid dims; variables: " << describeAll(vars));
        }
        if (candidates.size() > 1) {
            UDVR_FAIL(path.string() << ": several ensemble variables (" << describeAll(vars)
                                    << "); choose one with --var");
        }
        var = candidates[0];
    }

    return {*var, static_cast<std::size_t>(memberDimOf(*var))};
}

Ensemble readEnsembleNetcdfUnguarded(const fs::path& path, const EnsembleReadOptions& options) {
    NcFile file;
    file.id = openForRead(path);
    const auto [found, md] = findEnsembleVar(path, file.id, options);
    const VarInfo* var = &found;
    // The grid dims are the other three, in file order (z, y, x). View them as a 3D variable.
    VarInfo gridView = *var;
    gridView.dims.erase(gridView.dims.begin() + static_cast<std::ptrdiff_t>(md));
    gridView.lengths.erase(gridView.lengths.begin() + static_cast<std::ptrdiff_t>(md));
    gridView.dimNames.erase(gridView.dimNames.begin() + static_cast<std::ptrdiff_t>(md));
    std::size_t members = var->lengths[md];
    if (members < 2) {
        UDVR_FAIL(path.string() << ": variable " << var->name << " has " << members
                                << " member(s); an ensemble needs at least 2");
    }
    Ensemble e;
    std::string geometryNote;
    e.grid = gridFromCoordinates(path, file.id, gridView, 0, &geometryNote);
    if (members > static_cast<std::size_t>(INT32_MAX))
        UDVR_FAIL(path.string() << ": " << members << " members are too many");
    detail::checkedDataBytes(path, e.grid.dims, sizeof(float) * members);
    e.members = static_cast<int>(members);
    e.name = var->name;
    e.valueType = valueTypeOf(path, file.id, var->id);
    e.valueStep = valueStepOf(file.id, var->id, e.valueType);
    std::size_t n = e.grid.pointCount();
    detail::allocateEnsemble(e, options);
    std::vector<float> scratch(e.voxelMajor ? n : 0);  // one member, stored voxel-major after
    for (std::size_t m = 0; m < members; ++m) {
        std::vector<std::size_t> start(4, 0), count(var->lengths);
        start[md] = m;
        count[md] = 1;
        std::string what = " (member " + std::to_string(m) + ")";
        std::span<float> out =
            e.voxelMajor ? std::span<float>(scratch) : std::span<float>(e.values.data() + m * n, n);
        readSlab(path, file.id, *var, start, count, out, what, options.allowMissing);
        if (!options.allowMissing)
            detail::checkFinite(path, e.grid, out, 1, "member " + std::to_string(m));
        if (e.voxelMajor) detail::storeMember(e, static_cast<int>(m), out);
    }
    detail::printNote(geometryNote);  // only now: an error must stay the one line on stderr
    return e;
}

}  // namespace

void writeFieldNetcdf(const fs::path& path, const ScalarField& field) {
    const NetcdfLock lock(netcdfLibraryMutex());
    UDVR_CHECK_MSG(field.values.size() == field.grid.pointCount(), "field size vs grid");
    writeNetcdf(path, field.grid, safeName(field.name, "value"), 0, field.values);
}

void writeEnsembleNetcdf(const fs::path& path, const Ensemble& ensemble) {
    const NetcdfLock lock(netcdfLibraryMutex());
    UDVR_CHECK_MSG(ensemble.members >= 1 && !ensemble.voxelMajor &&
                       ensemble.values.size() ==
                           static_cast<std::size_t>(ensemble.members) * ensemble.grid.pointCount(),
                   "ensemble size vs grid (member-major)");
    writeNetcdf(path, ensemble.grid, safeName(ensemble.name, "value"), ensemble.members,
                ensemble.values);
}

namespace {

std::vector<ArrayInfo> listArraysNetcdfUnguarded(const fs::path& path) {
    const int nc = openForRead(path);
    std::vector<ArrayInfo> arrays;
    try {
        for (const VarInfo& v : allVars(path, nc)) {
            if (!isNumeric(nc, v.id) || isCoordinateVar(v)) continue;
            ArrayInfo info;
            info.name = v.name;
            info.type = valueTypeOf(path, nc, v.id);
            info.dimNames = v.dimNames;
            info.dimSizes = v.lengths;
            arrays.push_back(info);
        }
    } catch (...) {
        nc_close(nc);
        throw;
    }
    nc_close(nc);
    return arrays;
}

}  // namespace

ScalarField detail::readFieldNetcdf(const fs::path& path, const std::string& varName,
                                    std::string* geometryNote, bool allowMissing) {
    const NetcdfLock lock(netcdfLibraryMutex());
    return guardedRead(path, "field " + varName + (allowMissing ? " missing" : ""), [&] {
        return readFieldNetcdfUnguarded(path, varName, geometryNote, allowMissing);
    });
}

Ensemble detail::readEnsembleNetcdf(const fs::path& path, const EnsembleReadOptions& options) {
    const NetcdfLock lock(netcdfLibraryMutex());
    return guardedRead(path,
                       "ensemble " + options.var + " " + options.memberDim +
                           (options.allowMissing ? " missing" : "") +
                           (options.voxelMajor ? " voxel-major" : ""),
                       [&] { return readEnsembleNetcdfUnguarded(path, options); });
}

std::vector<ArrayInfo> detail::listArraysNetcdf(const fs::path& path) {
    const NetcdfLock lock(netcdfLibraryMutex());
    return guardedRead(path, "list", [&] { return listArraysNetcdfUnguarded(path); });
}

SlabReader detail::openFieldNetcdfSlabs(const fs::path& path, const std::string& varName,
                                        bool allowMissing) {
    const NetcdfLock lock(netcdfLibraryMutex());
    // Opened for each read: an ensemble of many member files must not hold a descriptor each.
    NcFile opened;
    opened.id = openForRead(path);
    const int nc = opened.id;
    const VarInfo var = findFieldVar(path, nc, varName);
    if (!isNumeric(nc, var.id)) {
        UDVR_FAIL(path.string() << ": variable " << var.name << " is not numeric");
    }
    const std::size_t first = var.dims.size() - 3;
    SlabReader r;
    r.grid = gridFromCoordinates(path, nc, var, first, &r.note);
    r.members = 1;
    r.name = var.name;
    r.valueType = valueTypeOf(path, nc, var.id);
    r.valueStep = valueStepOf(nc, var.id, r.valueType);
    const std::size_t plane =
        static_cast<std::size_t>(r.grid.dims[0]) * static_cast<std::size_t>(r.grid.dims[1]);
    r.scratchPerPlane = plane * sizeof(double);  // packed or filled values are read as double
    r.read = [var, path, first, plane, allowMissing](int z0, int z1, std::span<float> out) {
        const NetcdfLock readLock(netcdfLibraryMutex());
        // Checked (and an HDF5 file probed) when opened above; the plain open here.
        NcFile file;
        ncCheck(nc_open(path.c_str(), NC_NOWRITE, &file.id), path, "reopening");
        std::vector<std::size_t> start(var.dims.size(), 0), count(var.lengths);
        start[first] = static_cast<std::size_t>(z0);
        count[first] = static_cast<std::size_t>(z1 - z0);
        UDVR_CHECK(out.size() == count[first] * plane);
        readSlab(path, file.id, var, start, count, out,
                 " (z-planes " + std::to_string(z0) + " to " + std::to_string(z1 - 1) + ")",
                 allowMissing);
    };
    return r;
}

SlabReader detail::openEnsembleNetcdfSlabs(const fs::path& path,
                                           const EnsembleReadOptions& options) {
    const NetcdfLock lock(netcdfLibraryMutex());
    auto file = std::make_shared<NcFile>();
    file->id = openForRead(path);
    const std::pair<VarInfo, std::size_t> found = findEnsembleVar(path, file->id, options);
    const VarInfo var = found.first;
    const std::size_t md = found.second;  // (named copies: clang 14 cannot capture bindings)
    VarInfo gridView = var;
    gridView.dims.erase(gridView.dims.begin() + static_cast<std::ptrdiff_t>(md));
    gridView.lengths.erase(gridView.lengths.begin() + static_cast<std::ptrdiff_t>(md));
    gridView.dimNames.erase(gridView.dimNames.begin() + static_cast<std::ptrdiff_t>(md));
    const std::size_t members = var.lengths[md];
    if (members < 2) {
        UDVR_FAIL(path.string() << ": variable " << var.name << " has " << members
                                << " member(s); an ensemble needs at least 2");
    }
    SlabReader r;
    r.grid = gridFromCoordinates(path, file->id, gridView, 0, &r.note);
    if (members > static_cast<std::size_t>(INT32_MAX))
        UDVR_FAIL(path.string() << ": " << members << " members are too many");
    detail::checkedDataBytes(path, r.grid.dims, sizeof(float) * members);
    r.members = static_cast<int>(members);
    r.name = var.name;
    r.valueType = valueTypeOf(path, file->id, var.id);
    r.valueStep = valueStepOf(file->id, var.id, r.valueType);
    const std::size_t plane =
        static_cast<std::size_t>(r.grid.dims[0]) * static_cast<std::size_t>(r.grid.dims[1]);
    r.scratchPerPlane = plane * sizeof(double);  // one member's planes, packed: as double
    const std::size_t zd = md == 0 ? 1 : 0;      // z: the first of the other three dims
    const bool allowMissing = options.allowMissing;
    r.read = [file, var, md, zd, path, members, plane, allowMissing](int z0, int z1,
                                                                     std::span<float> out) {
        const NetcdfLock readLock(netcdfLibraryMutex());
        const std::size_t count1 = static_cast<std::size_t>(z1 - z0) * plane;
        UDVR_CHECK(out.size() == count1 * members);
        for (std::size_t m = 0; m < members; ++m) {
            std::vector<std::size_t> start(4, 0), count(var.lengths);
            start[md] = m;
            count[md] = 1;
            start[zd] = static_cast<std::size_t>(z0);
            count[zd] = static_cast<std::size_t>(z1 - z0);
            readSlab(path, file->id, var, start, count, out.subspan(m * count1, count1),
                     " (member " + std::to_string(m) + ", z-planes " + std::to_string(z0) + " to " +
                         std::to_string(z1 - 1) + ")",
                     allowMissing);
        }
    };
    return r;
}

std::pair<double, double> regularAxis(std::span<const double> c, const std::string& what) {
    UDVR_CHECK(!c.empty());
    for (double v : c)
        if (!std::isfinite(v)) UDVR_FAIL(what << " holds a non-finite value");
    const std::size_t len = c.size();
    if (len < 2) return {c[0], 1.0};
    const double s = (c[len - 1] - c[0]) / static_cast<double>(len - 1);
    if (!(s > 0.0))
        UDVR_FAIL(what << " must increase (first " << c[0] << ", last " << c[len - 1] << ")");
    // Float-stored coordinates round at about 1e-7 of their magnitude.
    const double tol = 1e-4 * s + 1e-6 * std::max(std::abs(c[0]), std::abs(c[len - 1]));
    for (std::size_t i = 0; i < len; ++i) {
        const double want = c[0] + static_cast<double>(i) * s;
        if (std::abs(c[i] - want) > tol)
            UDVR_FAIL(what << " is unevenly spaced (value " << i << " is " << c[i]
                           << ", an even axis has " << want << "); expected a regular grid");
    }
    return {c[0], s};
}

}  // namespace udvr
