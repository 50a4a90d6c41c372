// The field readers' format dispatch (raw_io.cpp, nrrd_io.cpp; VTK .vti and NetCDF .nc in
// vti_io.cpp and netcdf_io.cpp), the checks every reader shares, one file from a glob, and
// fields read as slabs of z-planes for the out-of-core build.
#include "udvr/io/field_io.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "udvr/io/io_detail.h"
#include "udvr/util/check.h"

namespace udvr {
namespace fs = std::filesystem;

namespace detail {

void checkFinite(const fs::path& path, const Grid3& grid, std::span<const float> values,
                 int components, const std::string& what) {
    std::size_t nans = 0, infs = 0, first = 0;
    for (std::size_t i = 0; i < values.size(); ++i) {
        float v = values[i];
        if (std::isfinite(v)) continue;
        if (nans + infs == 0) first = i;
        if (std::isnan(v)) {
            ++nans;
        } else {
            ++infs;
        }
    }
    if (nans + infs == 0) return;
    std::size_t voxel = first / static_cast<std::size_t>(components);
    std::size_t nx = static_cast<std::size_t>(std::max(grid.dims[0], 1));
    std::size_t ny = static_cast<std::size_t>(std::max(grid.dims[1], 1));
    UDVR_FAIL(path.string() << ": " << nans << " NaN and " << infs << " Inf values"
                            << (what.empty() ? "" : " in ") << what << ", the first at (i,j,k) = ("
                            << voxel % nx << "," << (voxel / nx) % ny << "," << voxel / (nx * ny)
                            << "); expected finite values");
}

void requireFile(const fs::path& path) {
    std::error_code ec;
    auto status = fs::status(path, ec);
    if (!fs::exists(status)) UDVR_FILE_FAIL("cannot read " << path.string() << ": no such file");
    if (!fs::is_regular_file(status)) {
        UDVR_FILE_FAIL("cannot read " << path.string() << ": not a regular file");
    }
}

std::string lowerExtension(const fs::path& path) {
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return ext;
}

/// Points × bytes per value of a grid, failing where that cannot be a file udvr can hold (it
/// would not fit in memory, or the product overflows).
std::size_t checkedDataBytes(const fs::path& path, const std::array<int, 3>& dims,
                             std::size_t valueSize) {
    long double bytes = static_cast<long double>(valueSize);
    for (int d : dims) bytes *= static_cast<long double>(d);
    if (bytes > static_cast<long double>(std::size_t{1} << 56))
        UDVR_FAIL(path.string() << ": dims " << dims[0] << "x" << dims[1] << "x" << dims[2]
                                << " are too large (" << static_cast<double>(bytes)
                                << " bytes of data)");
    return static_cast<std::size_t>(bytes);
}

std::string readWholeFile(const fs::path& path) {
    requireFile(path);
    std::ifstream in(path, std::ios::binary);
    if (!in) UDVR_FILE_FAIL("cannot open " << path.string());
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) UDVR_FILE_FAIL("cannot read " << path.string() << ": I/O error");
    return bytes;
}

void requireByteCount(const fs::path& path, std::size_t expected, std::size_t actual,
                      const std::string& what) {
    if (actual < expected) {
        UDVR_FAIL(path.string() << ": truncated " << what << ": expected " << expected
                                << " bytes, found " << actual);
    }
    if (actual > expected) {
        UDVR_FAIL(path.string() << ": dims do not match the " << what << " size: expected "
                                << expected << " bytes, found " << actual);
    }
}

}  // namespace detail

fs::path singleFileOf(const fs::path& path) {
    const std::string text = path.string();
    std::error_code ec;
    if (!detail::isGlobPattern(text) || fs::exists(path, ec)) return path;
    const std::vector<std::string> matches = detail::expandGlob(text);  // none: an error
    if (matches.size() == 1) return matches.front();
    UDVR_FAIL("pattern '" << text << "' matches " << matches.size() << " files (" << matches[0]
                          << ", " << matches[1] << (matches.size() > 2 ? ", ..." : "")
                          << ") where one field or model is read; an ensemble of them is built "
                             "with `udvr build` or rendered with --model members");
}

std::vector<std::string> withOneMatchResolved(const std::vector<std::string>& inputs) {
    std::error_code ec;
    if (inputs.size() != 1 || !detail::isGlobPattern(inputs[0]) || fs::exists(inputs[0], ec))
        return inputs;
    const std::vector<std::string> matches = detail::expandGlob(inputs[0]);
    return matches.size() == 1 ? matches : inputs;
}

namespace detail {

void printNote(const std::string& note) {
    if (!note.empty()) std::fprintf(stderr, "%s\n", note.c_str());
}

ScalarField readFieldImpl(const fs::path& given, const FieldReadOptions& options,
                          std::string* geometryNote) {
    const fs::path path = singleFileOf(given);
    requireFile(path);
    std::string ext = lowerExtension(path);
    ScalarField f;
    if (ext == ".nrrd" || ext == ".nhdr") {
        f = readNrrd(path, geometryNote);
    } else if (ext == ".vti" || ext == ".pvti") {
        f = readFieldVti(path, options.var, geometryNote);
    } else if (ext == ".nc" || ext == ".nc4" || ext == ".cdf") {
        f = readFieldNetcdf(path, options.var, geometryNote, options.allowMissing);
    } else if (ext == ".raw" || options.raw.given()) {
        f = readRaw(path, options.raw);
    } else {
        UDVR_FAIL("cannot read " << path.string() << ": unknown field format '" << ext
                                 << "' (expected .raw .nrrd .nhdr .vti .pvti .nc)");
    }
    // Every format's origin and spacing are finite; their far corner must be too (an origin of
    // 1.7e308 and a spacing of 1e308 put it at Inf).
    const std::array<double, 6> box = f.grid.bounds();
    for (double b : box)
        if (!std::isfinite(b))
            UDVR_FAIL(path.string() << ": the grid's origin and spacing put its far corner beyond "
                                       "the largest number");
    if (!options.allowMissing) checkFinite(path, f.grid, f.values);
    return f;
}

}  // namespace detail

ScalarField readField(const fs::path& path, const FieldReadOptions& options) {
    std::string note;
    ScalarField f = detail::readFieldImpl(path, options, &note);
    detail::printNote(note);
    return f;
}

void writeField(const fs::path& path, const ScalarField& field) {
    std::string ext = detail::lowerExtension(path);
    if (ext == ".vti") return writeFieldVti(path, field);
    if (ext == ".nc") return writeFieldNetcdf(path, field);
    UDVR_FAIL("cannot write " << path.string() << ": unknown field format '" << ext
                              << "' (expected .vti or .nc)");
}

// ---- slabs of z-planes (out-of-core build) -----------------------------------------------------

namespace {

/// Any field format, read whole for every slab and the slab's planes kept (VTI, NRRD). The read
/// that opens it serves the first slab.
SlabReader openWholeSlabs(const fs::path& path, const FieldReadOptions& options) {
    FieldReadOptions o = options;
    o.allowMissing = true;  // build's scan reports NaN/Inf
    SlabReader r;
    auto opened = std::make_shared<ScalarField>(detail::readFieldImpl(path, o, &r.note));
    r.grid = opened->grid;
    r.name = opened->name;
    r.valueType = opened->valueType;
    r.valueStep = opened->valueStep;
    r.members = 1;
    r.wholeMembers = true;
    // The values, and what the reader holds besides while reading: the file's bytes or VTK's
    // array in the file's type (up to 8 bytes a value) and the compressed data.
    r.scratchFixed = r.grid.pointCount() * (sizeof(float) + 2 * sizeof(double));
    const std::size_t plane =
        static_cast<std::size_t>(r.grid.dims[0]) * static_cast<std::size_t>(r.grid.dims[1]);
    const Grid3 grid = r.grid;
    r.read = [path, o, plane, grid, opened](int z0, int z1, std::span<float> out) mutable {
        ScalarField f = opened && !opened->values.empty() ? std::move(*opened)
                                                          : detail::readFieldImpl(path, o, nullptr);
        opened.reset();
        if (f.grid.dims != grid.dims) UDVR_FAIL(path.string() << " changed while build ran");
        UDVR_CHECK(out.size() == static_cast<std::size_t>(z1 - z0) * plane);
        std::copy_n(
            f.values.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(z0) * plane),
            out.size(), out.begin());
    };
    return r;
}

}  // namespace

SlabReader openFieldSlabs(const fs::path& given, const FieldReadOptions& options) {
    const fs::path path = singleFileOf(given);
    detail::requireFile(path);
    const std::string ext = detail::lowerExtension(path);
    if (ext == ".nc" || ext == ".nc4" || ext == ".cdf")
        return detail::openFieldNetcdfSlabs(path, options.var, options.allowMissing);
    if (ext == ".nrrd" || ext == ".nhdr" || ext == ".vti") return openWholeSlabs(path, options);
    if (ext == ".raw" || options.raw.given()) return detail::openRawSlabs(path, options.raw);
    UDVR_FAIL("cannot read " << path.string() << ": unknown field format '" << ext
                             << "' (expected .raw .nrrd .nhdr .vti .nc)");
}

}  // namespace udvr
