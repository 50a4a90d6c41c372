// Ensembles from one NetCDF variable with a member dimension, or from ≥2 member files (SPEC §7).
#include "udvr/io/ensemble_io.h"

#include <glob.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <memory>
#include <string_view>

#include "udvr/io/io_detail.h"
#include "udvr/util/check.h"
#include "udvr/util/large_vector.h"

namespace udvr {
namespace fs = std::filesystem;

namespace {

/// Natural order: digit runs compare as numbers, so member_2 sorts before member_10.
bool naturalLess(std::string_view a, std::string_view b) {
    std::size_t i = 0, j = 0;
    auto isDigit = [](char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; };
    while (i < a.size() && j < b.size()) {
        if (isDigit(a[i]) && isDigit(b[j])) {
            std::size_t ie = i, je = j;
            while (ie < a.size() && isDigit(a[ie])) ++ie;
            while (je < b.size() && isDigit(b[je])) ++je;
            std::string_view da = a.substr(i, ie - i), db = b.substr(j, je - j);
            da.remove_prefix(std::min(da.find_first_not_of('0'), da.size()));
            db.remove_prefix(std::min(db.find_first_not_of('0'), db.size()));
            if (da.size() != db.size()) return da.size() < db.size();
            if (da != db) return da < db;
            i = ie;
            j = je;
        } else {
            if (a[i] != b[j]) return a[i] < b[j];
            ++i;
            ++j;
        }
    }
    if (a.size() - i != b.size() - j) return a.size() - i < b.size() - j;
    return a < b;  // equal up to leading zeros: fall back to plain order
}

bool sameGrid(const Grid3& a, const Grid3& b) {
    if (a.dims != b.dims) return false;
    for (int i = 0; i < 3; ++i) {
        double tol = 1e-6 * std::max(a.spacing[i], b.spacing[i]);
        if (std::abs(a.spacing[i] - b.spacing[i]) > tol) return false;
        if (std::abs(a.origin[i] - b.origin[i]) > tol) return false;
    }
    return true;
}

std::string gridText(const Grid3& g) {
    std::ostringstream os;
    os << g.dims[0] << "x" << g.dims[1] << "x" << g.dims[2] << " origin (" << g.origin[0] << ","
       << g.origin[1] << "," << g.origin[2] << ") spacing (" << g.spacing[0] << "," << g.spacing[1]
       << "," << g.spacing[2] << ")";
    return os.str();
}

}  // namespace

bool detail::isGlobPattern(const std::string& s) {
    return s.find_first_of("*?[") != std::string::npos;
}

std::vector<std::string> detail::expandGlob(const std::string& pattern) {
    glob_t g{};
    int status = ::glob(pattern.c_str(), 0, nullptr, &g);
    std::vector<std::string> out;
    if (status == 0) {
        for (std::size_t i = 0; i < g.gl_pathc; ++i) out.emplace_back(g.gl_pathv[i]);
    }
    globfree(&g);
    if (status == GLOB_NOMATCH || (status == 0 && out.empty())) {
        UDVR_FAIL("pattern '" << pattern << "' matches no files");
    }
    if (status != 0) UDVR_FAIL("cannot expand pattern '" << pattern << "'");
    return out;
}

void detail::allocateEnsemble(Ensemble& e, const EnsembleReadOptions& options) {
    if (options.checkSize) options.checkSize(e.members, e.grid);
    e.voxelMajor = options.voxelMajor;
    resizeLarge(e.values, e.grid.pointCount() * static_cast<std::size_t>(e.members));
}

void detail::storeMember(Ensemble& e, int m, std::span<const float> values) {
    const std::size_t n = e.grid.pointCount(), members = static_cast<std::size_t>(e.members);
    UDVR_CHECK_MSG(values.size() == n && m >= 0 && m < e.members, "member size vs grid");
    if (!e.voxelMajor) {
        std::copy(values.begin(), values.end(), e.member(m));
        return;
    }
    float* out = e.values.data() + m;
    for (std::size_t p = 0; p < n; ++p) out[p * members] = values[p];
}

namespace {

/// The member files of `inputs` (globs expanded, in natural order), or the one NetCDF file of
/// a member-dimension ensemble (a list of one).
std::vector<std::string> ensembleFiles(const std::vector<std::string>& inputs) {
    std::vector<std::string> files;
    for (const auto& in : inputs) {
        if (detail::isGlobPattern(in) && !fs::exists(in)) {
            auto matches = detail::expandGlob(in);
            files.insert(files.end(), matches.begin(), matches.end());
        } else {
            files.push_back(in);
        }
    }
    if (files.empty()) UDVR_FAIL("no ensemble input given (one .nc file or at least 2 members)");
    if (files.size() == 1) {
        std::string ext = detail::lowerExtension(files[0]);
        if (ext == ".nc" || ext == ".nc4" || ext == ".cdf") return files;
        detail::requireFile(files[0]);
        UDVR_FAIL("an ensemble needs at least 2 member files, got 1 (" << files[0] << ")");
    }
    std::sort(files.begin(), files.end(),
              [](const std::string& a, const std::string& b) { return naturalLess(a, b); });
    for (std::size_t i = 1; i < files.size(); ++i) {
        if (fs::path(files[i]).lexically_normal() == fs::path(files[i - 1]).lexically_normal()) {
            UDVR_FAIL("member file " << files[i] << " is given twice");
        }
    }
    return files;
}

/// Members whose arrays are named (.vti, .pvti, .nc) must name the array alike unless --var
/// picks it: `ImageFile` in one member and `density` in another are likely different
/// quantities, not one ensemble (issue 35).
void requireSameArrayName(const std::string& file, const std::string& name,
                          const std::string& first, const std::string& firstName,
                          const std::string& var) {
    const std::string ext = detail::lowerExtension(file);
    const bool named = ext == ".vti" || ext == ".pvti" || ext == ".nc" || ext == ".nc4";
    if (!var.empty() || !named || name == firstName) return;
    UDVR_FAIL("ensemble members name their arrays differently: "
              << file << " holds '" << name << "', " << first << " holds '" << firstName
              << "'; --var NAME reads the array NAME from every member");
}

}  // namespace

Ensemble readEnsemble(const std::vector<std::string>& inputs, const EnsembleReadOptions& options) {
    const std::vector<std::string> files = ensembleFiles(inputs);
    if (files.size() == 1) return detail::readEnsembleNetcdf(files[0], options);

    FieldReadOptions fieldOptions;
    fieldOptions.raw = options.raw;
    fieldOptions.var = options.var;
    fieldOptions.allowMissing = options.allowMissing;
    Ensemble e;
    e.members = static_cast<int>(files.size());
    std::string note;  // about member 0's geometry; printed once all members have been read
    for (std::size_t m = 0; m < files.size(); ++m) {
        ScalarField f = detail::readFieldImpl(files[m], fieldOptions, m == 0 ? &note : nullptr);
        if (m == 0) {
            e.grid = f.grid;
            e.name = f.name;
            e.valueType = f.valueType;
            e.valueStep = f.valueStep;
            detail::allocateEnsemble(e, options);
        } else if (!sameGrid(f.grid, e.grid)) {
            UDVR_FAIL("ensemble members on different grids: "
                      << files[m] << " is " << gridText(f.grid) << ", " << files[0] << " is "
                      << gridText(e.grid));
        }
        if (m > 0) requireSameArrayName(files[m], f.name, files[0], e.name, options.var);
        if (m > 0 && (f.valueType != e.valueType || f.valueStep != e.valueStep)) {
            e.valueType = "mixed";  // members of different types: no one quantisation step
            e.valueStep = 0.0;
        }
        detail::storeMember(e, static_cast<int>(m), f.values);
    }
    detail::printNote(note);
    return e;
}

SlabReader openEnsembleSlabs(const std::vector<std::string>& inputs,
                             const EnsembleReadOptions& options) {
    const std::vector<std::string> files = ensembleFiles(inputs);
    if (files.size() == 1) return detail::openEnsembleNetcdfSlabs(files[0], options);
    FieldReadOptions fieldOptions;
    fieldOptions.raw = options.raw;
    fieldOptions.var = options.var;
    fieldOptions.allowMissing = options.allowMissing;
    auto members = std::make_shared<std::vector<SlabReader>>();
    SlabReader e;
    e.members = static_cast<int>(files.size());
    for (std::size_t m = 0; m < files.size(); ++m) {
        const std::string ext = detail::lowerExtension(files[m]);
        if (m > 0 && (ext == ".vti" || ext == ".nrrd" || ext == ".nhdr")) {
            // Read whole for every slab anyway: opened (and its grid checked) at each read, so
            // that opening the ensemble does not read every member once more.
            detail::requireFile(files[m]);
            SlabReader lazy;
            lazy.wholeMembers = true;
            const std::string file = files[m], first = files[0], firstName = e.name;
            const Grid3 grid = e.grid;
            lazy.read = [file, first, firstName, grid, fieldOptions](int z0, int z1,
                                                                     std::span<float> out) {
                SlabReader f = openFieldSlabs(file, fieldOptions);
                if (!sameGrid(f.grid, grid))
                    UDVR_FAIL("ensemble members on different grids: "
                              << file << " is " << gridText(f.grid) << ", " << first << " is "
                              << gridText(grid));
                requireSameArrayName(file, f.name, first, firstName, fieldOptions.var);
                f.read(z0, z1, out);
            };
            members->push_back(std::move(lazy));
            continue;
        }
        SlabReader f = openFieldSlabs(files[m], fieldOptions);
        if (m == 0) {
            e.grid = f.grid;
            e.name = f.name;
            e.valueType = f.valueType;
            e.valueStep = f.valueStep;
            e.note = f.note;
        } else if (!sameGrid(f.grid, e.grid)) {
            UDVR_FAIL("ensemble members on different grids: "
                      << files[m] << " is " << gridText(f.grid) << ", " << files[0] << " is "
                      << gridText(e.grid));
        }
        if (m > 0) requireSameArrayName(files[m], f.name, files[0], e.name, options.var);
        if (m > 0 && (f.valueType != e.valueType || f.valueStep != e.valueStep)) {
            e.valueType = "mixed";
            e.valueStep = 0.0;
        }
        // Members are read one after another: the largest scratch counts.
        e.scratchPerPlane = std::max(e.scratchPerPlane, f.scratchPerPlane);
        e.scratchFixed = std::max(e.scratchFixed, f.scratchFixed);
        e.wholeMembers = e.wholeMembers || f.wholeMembers;
        members->push_back(std::move(f));
    }
    const std::size_t plane =
        static_cast<std::size_t>(e.grid.dims[0]) * static_cast<std::size_t>(e.grid.dims[1]);
    e.read = [members, plane](int z0, int z1, std::span<float> out) {
        const std::size_t count = static_cast<std::size_t>(z1 - z0) * plane;
        UDVR_CHECK(out.size() == count * members->size());
        for (std::size_t m = 0; m < members->size(); ++m)
            (*members)[m].read(z0, z1, out.subspan(m * count, count));
    };
    return e;
}

}  // namespace udvr
