#include "vtkUdvrNetCDFEnsembleReader.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <tuple>
#include <vector>

#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtk_netcdf.h"

vtkStandardNewMacro(vtkUdvrNetCDFEnsembleReader);

namespace {
// udvr's member dimension names (io/netcdf_io.cpp, `udvr build`).
constexpr const char* kMemberDimNames[] = {"member", "ensemble", "realization", "number"};

[[noreturn]] void fail(const std::string& path, const std::string& what) {
    throw std::runtime_error(path + ": " + what);
}

void check(int status, const std::string& path, const std::string& what) {
    if (status != NC_NOERR) fail(path, what + ": " + nc_strerror(status));
}

struct File {
    int id = -1;
    ~File() {
        if (id >= 0) nc_close(id);
    }
};

// The ensemble variable of an open file: its id, name, the index of its member dimension, the
// dims' ids, lengths and names in file order.
struct EnsembleVar {
    int id = -1;
    std::string name;
    int memberDim = -1;
    std::array<int, 4> dims{};
    std::array<std::size_t, 4> lengths{};
    std::array<std::string, 4> dimNames;
    int gridDim(int axis) const {  // file dim of grid axis 0 (x, fastest) … 2
        int g = 2 - axis;          // the grid dims in file order are z, y, x
        for (int d = 0; d < 4; ++d) {
            if (d == memberDim) continue;
            if (g-- == 0) return d;
        }
        return -1;
    }
};

bool isNumeric(nc_type t) {
    return t == NC_BYTE || t == NC_UBYTE || t == NC_SHORT || t == NC_USHORT || t == NC_INT ||
           t == NC_UINT || t == NC_INT64 || t == NC_UINT64 || t == NC_FLOAT || t == NC_DOUBLE;
}

EnsembleVar findEnsembleVar(int nc, const std::string& path) {
    int nvars = 0;
    check(nc_inq_nvars(nc, &nvars), path, "variables");
    std::vector<EnsembleVar> found;
    std::string all;
    for (int v = 0; v < nvars; ++v) {
        char name[NC_MAX_NAME + 1];
        int ndims = 0;
        nc_type type;
        check(nc_inq_var(nc, v, name, &type, &ndims, nullptr, nullptr), path, "variable");
        std::vector<int> dims(static_cast<std::size_t>(std::max(ndims, 0)));
        if (ndims > 0) check(nc_inq_vardimid(nc, v, dims.data()), path, "variable dims");
        std::string describe = std::string(name) + "(";
        EnsembleVar e;
        e.id = v;
        e.name = name;
        for (int d = 0; d < ndims; ++d) {
            char dimName[NC_MAX_NAME + 1];
            std::size_t length = 0;
            check(nc_inq_dim(nc, dims[static_cast<std::size_t>(d)], dimName, &length), path,
                  "dimension");
            describe += (d ? "," : "") + std::string(dimName) + "=" + std::to_string(length);
            if (d < 4) {
                e.dims[static_cast<std::size_t>(d)] = dims[static_cast<std::size_t>(d)];
                e.lengths[static_cast<std::size_t>(d)] = length;
                e.dimNames[static_cast<std::size_t>(d)] = dimName;
            }
            if (e.memberDim < 0 && std::find(std::begin(kMemberDimNames), std::end(kMemberDimNames),
                                             std::string(dimName)) != std::end(kMemberDimNames))
                e.memberDim = d;
        }
        all += (all.empty() ? "" : ", ") + describe + ")";
        if (ndims == 4 && e.memberDim >= 0 && isNumeric(type)) found.push_back(e);
    }
    if (found.empty())
        fail(path,
             "no variable with a member dimension (member, ensemble, realization or number) and "
             "3 grid dims; variables: " +
                 (all.empty() ? std::string("none") : all));
    if (found.size() > 1) fail(path, "several ensemble variables (" + all + ")");
    const EnsembleVar& e = found[0];
    if (e.lengths[static_cast<std::size_t>(e.memberDim)] < 2)
        fail(path, "variable " + e.name + " has " +
                       std::to_string(e.lengths[static_cast<std::size_t>(e.memberDim)]) +
                       " member(s); an ensemble needs at least 2");
    for (int a = 0; a < 3; ++a) {
        const std::size_t n = e.lengths[static_cast<std::size_t>(e.gridDim(a))];
        if (n < 1 || n > static_cast<std::size_t>(std::numeric_limits<int>::max()))
            fail(path, "dimension " + e.dimNames[static_cast<std::size_t>(e.gridDim(a))] +
                           " has length " + std::to_string(n));
    }
    return e;
}

// Origin and spacing of grid axis `axis` from its CF coordinate variable (evenly spaced, as
// udvr's regularAxis checks it), else 0 and 1.
std::pair<double, double> axisGeometry(int nc, const EnsembleVar& e, int axis,
                                       const std::string& path) {
    const int d = e.gridDim(axis);
    const std::string& dimName = e.dimNames[static_cast<std::size_t>(d)];
    const std::size_t n = e.lengths[static_cast<std::size_t>(d)];
    int cid = -1, ndims = 0, cdim = -1;
    if (nc_inq_varid(nc, dimName.c_str(), &cid) != NC_NOERR ||
        nc_inq_varndims(nc, cid, &ndims) != NC_NOERR || ndims != 1 ||
        nc_inq_vardimid(nc, cid, &cdim) != NC_NOERR || cdim != e.dims[static_cast<std::size_t>(d)])
        return {0.0, 1.0};
    std::vector<double> c(n);
    check(nc_get_var_double(nc, cid, c.data()), path, "coordinate variable " + dimName);
    const std::string what = "coordinate variable " + dimName;
    for (double v : c)
        if (!std::isfinite(v)) fail(path, what + " holds a non-finite value");
    if (n < 2) return {c[0], 1.0};
    const double s = (c[n - 1] - c[0]) / static_cast<double>(n - 1);
    if (!(s > 0.0)) fail(path, what + " must increase");
    const double tol = 1e-4 * s + 1e-6 * std::max(std::abs(c[0]), std::abs(c[n - 1]));
    for (std::size_t i = 0; i < n; ++i)
        if (std::abs(c[i] - (c[0] + static_cast<double>(i) * s)) > tol)
            fail(path, what + " is unevenly spaced; expected a regular grid");
    return {c[0], s};
}

// A classic-format file (CDF-1, -2, -5) cut short reads as zeros in netCDF-C, without an error:
// its length must reach the end of its fixed-size variables' data. That end is at least the
// header's length (the classic format's fields, computed from the file's dims, attributes and
// variables; netCDF-C writes no padding after it unless asked) plus each variable's data, padded
// to 4 bytes but the last: a lower bound, exact for netCDF-C's files.
void checkClassicLength(int nc, const std::string& path) {
    int format = 0;
    check(nc_inq_format(nc, &format), path, "format");
    if (format != NC_FORMAT_CLASSIC && format != NC_FORMAT_64BIT_OFFSET && format != NC_FORMAT_CDF5)
        return;
    using Bytes = unsigned long long;
    const Bytes count = format == NC_FORMAT_CDF5 ? 8 : 4;  // NON_NEG: counts, lengths, ids
    const Bytes offset = format == NC_FORMAT_CLASSIC ? 4 : 8;
    const auto pad4 = [](Bytes b) { return (b + 3) / 4 * 4; };
    const auto typeSize = [&](nc_type type) {
        std::size_t size = 0;
        check(nc_inq_type(nc, type, nullptr, &size), path, "type");
        return static_cast<Bytes>(size);
    };
    const auto name = [&](const char* text) { return count + pad4(std::strlen(text)); };
    const auto attributes = [&](int varid, int natts) {
        Bytes bytes = 4 + count;  // tag, count
        for (int i = 0; i < natts; ++i) {
            char attName[NC_MAX_NAME + 1];
            nc_type type;
            std::size_t length = 0;
            check(nc_inq_attname(nc, varid, i, attName), path, "attribute");
            check(nc_inq_att(nc, varid, attName, &type, &length), path, "attribute");
            bytes += name(attName) + 4 + count + pad4(length * typeSize(type));
        }
        return bytes;
    };
    int ndims = 0, nvars = 0, ngatts = 0, unlimited = -1;
    check(nc_inq(nc, &ndims, &nvars, &ngatts, &unlimited), path, "header");
    Bytes header = 4 + count;  // magic, numrecs
    header += 4 + count;       // dimension list
    for (int d = 0; d < ndims; ++d) {
        char dimName[NC_MAX_NAME + 1];
        check(nc_inq_dimname(nc, d, dimName), path, "dimension");
        header += name(dimName) + count;
    }
    header += attributes(NC_GLOBAL, ngatts);
    header += 4 + count;  // variable list
    Bytes data = 0, lastPad = 0;
    for (int v = 0; v < nvars; ++v) {
        char varName[NC_MAX_NAME + 1];
        nc_type type;
        int vdims = 0, natts = 0;
        check(nc_inq_var(nc, v, varName, &type, &vdims, nullptr, &natts), path, "variable");
        header += name(varName) + count + static_cast<Bytes>(vdims) * count + attributes(v, natts) +
                  4 + count + offset;
        std::vector<int> dims(static_cast<std::size_t>(std::max(vdims, 0)));
        if (vdims > 0) check(nc_inq_vardimid(nc, v, dims.data()), path, "variable dims");
        if (vdims > 0 && dims[0] == unlimited) continue;  // record data: not counted
        Bytes bytes = typeSize(type);
        for (int d : dims) {
            std::size_t length = 0;
            check(nc_inq_dimlen(nc, d, &length), path, "dimension");
            bytes *= length;
        }
        data += pad4(bytes);
        lastPad = pad4(bytes) - bytes;
    }
    const Bytes needed = header + data - lastPad;
    std::error_code error;
    const auto length = std::filesystem::file_size(path, error);
    if (error) fail(path, "cannot read its size: " + error.message());
    if (length < needed)
        fail(path, "the file is cut short: " + std::to_string(length) +
                       " bytes, its header and "
                       "data take at least " +
                       std::to_string(needed));
}
}  // namespace

vtkUdvrNetCDFEnsembleReader::vtkUdvrNetCDFEnsembleReader() { this->SetNumberOfInputPorts(0); }

int vtkUdvrNetCDFEnsembleReader::CanReadFile(const char* fileName) {
    if (!fileName) return 0;
    File f;
    if (nc_open(fileName, NC_NOWRITE, &f.id) != NC_NOERR) return 0;
    try {
        findEnsembleVar(f.id, fileName);
        return 1;
    } catch (const std::exception&) {
        return 0;
    }
}

int vtkUdvrNetCDFEnsembleReader::RequestInformation(vtkInformation*, vtkInformationVector**,
                                                    vtkInformationVector* outputVector) {
    vtkInformation* out = outputVector->GetInformationObject(0);
    try {
        if (this->FileName.empty()) throw std::runtime_error("no file name");
        File f;
        check(nc_open(this->FileName.c_str(), NC_NOWRITE, &f.id), this->FileName,
              "cannot open as NetCDF");
        const EnsembleVar e = findEnsembleVar(f.id, this->FileName);
        int whole[6];
        double origin[3], spacing[3];
        for (int a = 0; a < 3; ++a) {
            whole[2 * a] = 0;
            whole[2 * a + 1] =
                static_cast<int>(e.lengths[static_cast<std::size_t>(e.gridDim(a))]) - 1;
            std::tie(origin[a], spacing[a]) = axisGeometry(f.id, e, a, this->FileName);
        }
        out->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole, 6);
        out->Set(vtkDataObject::ORIGIN(), origin, 3);
        out->Set(vtkDataObject::SPACING(), spacing, 3);
        out->Set(vtkAlgorithm::CAN_PRODUCE_SUB_EXTENT(), 1);
    } catch (const std::exception& ex) {
        vtkErrorMacro(<< "udvr: " << ex.what());
        return 0;
    }
    return 1;
}

int vtkUdvrNetCDFEnsembleReader::RequestData(vtkInformation*, vtkInformationVector**,
                                             vtkInformationVector* outputVector) {
    vtkInformation* outInfo = outputVector->GetInformationObject(0);
    vtkImageData* output = vtkImageData::GetData(outputVector);
    if (!output) return 0;
    try {
        File f;
        check(nc_open(this->FileName.c_str(), NC_NOWRITE, &f.id), this->FileName,
              "cannot open as NetCDF");
        const EnsembleVar e = findEnsembleVar(f.id, this->FileName);
        checkClassicLength(f.id, this->FileName);
        int ext[6];
        outInfo->Get(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), ext);
        output->SetExtent(ext);
        double origin[3], spacing[3];
        for (int a = 0; a < 3; ++a)
            std::tie(origin[a], spacing[a]) = axisGeometry(f.id, e, a, this->FileName);
        output->SetOrigin(origin);
        output->SetSpacing(spacing);
        std::size_t n = 1;
        std::array<std::size_t, 4> start{}, count{};
        for (int a = 0; a < 3; ++a) {
            if (ext[2 * a + 1] < ext[2 * a]) return 1;  // an empty piece
            const auto d = static_cast<std::size_t>(e.gridDim(a));
            start[d] = static_cast<std::size_t>(ext[2 * a]);
            count[d] = static_cast<std::size_t>(ext[2 * a + 1] - ext[2 * a] + 1);
            n *= count[d];
        }
        // CF packing and fill values, as udvr's reader applies and rejects them.
        double scale = 1.0, offset = 0.0;
        std::vector<double> fills;
        const auto attribute = [&](const char* name, std::vector<double>& values) {
            std::size_t length = 0;
            nc_type type;
            if (nc_inq_att(f.id, e.id, name, &type, &length) != NC_NOERR || length == 0 ||
                type == NC_CHAR || type == NC_STRING)
                return;
            std::vector<double> v(length);
            if (nc_get_att_double(f.id, e.id, name, v.data()) == NC_NOERR)
                values.insert(values.end(), v.begin(), v.end());
        };
        std::vector<double> scales, offsets;
        attribute("scale_factor", scales);
        attribute("add_offset", offsets);
        attribute("_FillValue", fills);
        attribute("missing_value", fills);
        if (!scales.empty()) scale = scales[0];
        if (!offsets.empty()) offset = offsets[0];

        const std::size_t members = e.lengths[static_cast<std::size_t>(e.memberDim)];
        const int digits = std::max(3, static_cast<int>(std::to_string(members - 1).size()));
        std::vector<double> raw(n);
        vtkPointData* pd = output->GetPointData();
        for (std::size_t m = 0; m < members; ++m) {
            start[static_cast<std::size_t>(e.memberDim)] = m;
            count[static_cast<std::size_t>(e.memberDim)] = 1;
            const std::string what = "variable " + e.name + " (member " + std::to_string(m) + ")";
            check(nc_get_vara_double(f.id, e.id, start.data(), count.data(), raw.data()),
                  this->FileName, "reading " + what);
            vtkNew<vtkFloatArray> a;
            std::string index = std::to_string(m);
            index.insert(
                0, static_cast<std::size_t>(digits) - std::min<std::size_t>(index.size(), digits),
                '0');
            a->SetName((e.name + "_" + index).c_str());
            a->SetNumberOfTuples(static_cast<vtkIdType>(n));
            float* out = a->GetPointer(0);
            for (std::size_t i = 0; i < n; ++i) {
                if (std::find(fills.begin(), fills.end(), raw[i]) != fills.end())
                    fail(this->FileName, what +
                                             " has missing (fill) values; expected a "
                                             "complete field");
                const double v = raw[i] * scale + offset;
                if (!std::isfinite(v) || std::abs(v) > std::numeric_limits<float>::max())
                    fail(this->FileName, what +
                                             " has a non-finite value or one outside the "
                                             "float32 range");
                out[i] = static_cast<float>(v);
            }
            pd->AddArray(a);
        }
    } catch (const std::exception& ex) {
        output->Initialize();
        vtkErrorMacro(<< "udvr: " << ex.what());
        return 0;
    }
    return 1;
}

void vtkUdvrNetCDFEnsembleReader::PrintSelf(ostream& os, vtkIndent indent) {
    this->Superclass::PrintSelf(os, indent);
    os << indent << "FileName: " << this->FileName << "\n";
}
