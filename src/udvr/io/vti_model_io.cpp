// Model volumes as VTK XML ImageData (SPEC §7): .vti, and .pvti written and read piece by piece.
#include <vtkDataArray.h>
#include <vtkFieldData.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkPointData.h>
#include <vtkSmartPointer.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "udvr/classify/tf_presets.h"
#include "udvr/io/field_io.h"
#include "udvr/io/io_detail.h"
#include "udvr/io/model_io.h"
#include "udvr/io/transfer_function_2d_io.h"
#include "udvr/io/vti_check.h"
#include "udvr/io/vtk_image.h"
#include "udvr/stats/model_field_data.h"
#include "udvr/util/atomic_file.h"
#include "udvr/util/check.h"

namespace udvr {
namespace fs = std::filesystem;
using namespace vtkio;

// ---- models ------------------------------------------------------------------------------------

/// The model's field data (SPEC §7).
/// hasQuantiles/hasGmm: whether the file holds those arrays.
void vtkio::addModelFieldData(vtkFieldData* fd, const ModelVolume& model, bool hasQuantiles,
                              bool hasGmm) {
    for (ModelFieldDatum& d : modelFieldData(model, hasQuantiles, hasGmm)) {
        if (const int* i = std::get_if<int>(&d.value))
            addInt(fd, d.name, *i);
        else if (auto* doubles = std::get_if<std::vector<double>>(&d.value))
            addDouble(fd, d.name, std::move(*doubles));
        else
            addString(fd, d.name, std::get<std::string>(d.value));
    }
}

namespace {

/// f(values, components, name) for each point array of a model file, in file order (SPEC §7);
/// an absent array has empty values.
template <typename F>
void forEachModelArray(const ModelVolume& model, F&& f) {
    for (const ModelFileArray& a : kModelFileArrays)
        f(model.*a.values, a.floatsPerVoxel(model), a.name);
}

/// The model's planes k0 … k1 (z) as an image whose extent is those planes of the whole grid
/// (the origin stays the grid's), with the model's field data.
vtkSmartPointer<vtkImageData> modelImage(const ModelVolume& model, int k0, int k1) {
    const std::size_t n = model.voxelCount();
    const std::size_t plane = static_cast<std::size_t>(model.grid.dims[0]) * model.grid.dims[1];
    UDVR_CHECK(0 <= k0 && k0 <= k1 && k1 < model.grid.dims[2]);
    auto image = makeImage(model.grid);
    image->SetExtent(0, model.grid.dims[0] - 1, 0, model.grid.dims[1] - 1, k0, k1);
    vtkPointData* pd = image->GetPointData();
    auto add = [&](const std::vector<float>& values, int components, const char* name) {
        if (values.empty()) return;
        UDVR_CHECK_MSG(values.size() == n * static_cast<std::size_t>(components),
                       std::string("model array size: ") + name);
        if (k0 == 0 && k1 == model.grid.dims[2] - 1) {
            pd->AddArray(wrapFloats(values, components, name));
            return;
        }
        // A copy of the planes (wrapFloats does not copy).
        const std::size_t c = static_cast<std::size_t>(components);
        const std::size_t begin = plane * c * static_cast<std::size_t>(k0);
        const std::size_t count = plane * c * static_cast<std::size_t>(k1 - k0 + 1);
        auto array = vtkSmartPointer<vtkFloatArray>::New();
        array->SetName(name);
        array->SetNumberOfComponents(components);
        array->SetNumberOfValues(static_cast<vtkIdType>(count));
        std::copy_n(values.begin() + static_cast<std::ptrdiff_t>(begin), count,
                    array->GetPointer(0));
        pd->AddArray(array);
    };
    forEachModelArray(model, add);
    if (!model.mean.empty()) pd->SetActiveScalars("mean");

    addModelFieldData(image->GetFieldData(), model, model.hasQuantiles(), model.hasGmm());
    return image;
}

}  // namespace

void writeModelVti(const fs::path& path, const ModelVolume& model, bool compress) {
    writeImageData(path, modelImage(model, 0, model.grid.dims[2] - 1),
                   compress ? Compression::Lz4 : Compression::None);
}

std::size_t modelArrayBytes(const Grid3& grid, int quantileCount, int gmmComponents) {
    std::size_t floats = 0;
    for (const ModelFileArray& a : kModelFileArrays)
        floats += static_cast<std::size_t>(a.floatsPerVoxel(quantileCount, gmmComponents));
    return grid.pointCount() * floats * sizeof(float);
}

std::vector<int> pvtiPieceBoundaries(int planes, int pieces) {
    UDVR_CHECK(planes >= 1 && pieces >= 1);
    const int cells = std::max(planes - 1, 1);
    pieces = std::min(pieces, cells);
    std::vector<int> b(static_cast<std::size_t>(pieces) + 1);
    for (int i = 0; i <= pieces; ++i)
        b[static_cast<std::size_t>(i)] =
            static_cast<int>(static_cast<long long>(i) * (planes - 1) / pieces);
    return b;
}

void writeModelPvtiPiece(const fs::path& path, const ModelVolume& model, int piece, int k0, int k1,
                         int modelFirstPlane) {
    const fs::path file = path.parent_path() / pieceSource(path, piece);
    std::error_code ec;
    fs::create_directories(file.parent_path(), ec);
    if (ec)
        UDVR_FILE_FAIL("cannot write " << path.string() << ": cannot create the folder "
                                       << file.parent_path().string() << ": " << ec.message());
    auto image = modelImage(model, k0 - modelFirstPlane, k1 - modelFirstPlane);
    if (modelFirstPlane != 0) {
        // `model` holds planes from modelFirstPlane on: the extent and origin of the whole grid.
        image->SetExtent(0, model.grid.dims[0] - 1, 0, model.grid.dims[1] - 1, k0, k1);
        image->SetOrigin(model.grid.origin[0], model.grid.origin[1],
                         model.grid.origin[2] - modelFirstPlane * model.grid.spacing[2]);
    }
    writeImageData(file, image, Compression::Lz4);
}

void writeModelPvtiHeader(const fs::path& path, const ModelVolume& model,
                          const std::vector<int>& boundaries) {
    const Grid3& g = model.grid;
    std::ostringstream x;
    x.precision(17);
    x << "<?xml version=\"1.0\"?>\n"
      << "<VTKFile type=\"PImageData\" version=\"1.0\" byte_order=\"LittleEndian\" "
         "header_type=\"UInt64\" compressor=\"vtkLZ4DataCompressor\">\n"
      << "  <PImageData WholeExtent=\"0 " << g.dims[0] - 1 << " 0 " << g.dims[1] - 1 << " 0 "
      << g.dims[2] - 1 << "\" GhostLevel=\"0\" Origin=\"" << g.origin[0] << " " << g.origin[1]
      << " " << g.origin[2] << "\" Spacing=\"" << g.spacing[0] << " " << g.spacing[1] << " "
      << g.spacing[2] << "\" Direction=\"1 0 0 0 1 0 0 0 1\">\n"
      << "    <PPointData" << (model.mean.empty() ? "" : " Scalars=\"mean\"") << ">\n";
    auto array = [&](const std::vector<float>& values, int components, const char* name) {
        if (values.empty()) return;
        x << "      <PDataArray type=\"Float32\" Name=\"" << name << "\"";
        if (components > 1) x << " NumberOfComponents=\"" << components << "\"";
        x << "/>\n";
    };
    forEachModelArray(model, array);
    x << "    </PPointData>\n";
    for (std::size_t i = 0; i + 1 < boundaries.size(); ++i)
        x << "    <Piece Extent=\"0 " << g.dims[0] - 1 << " 0 " << g.dims[1] - 1 << " "
          << boundaries[i] << " " << boundaries[i + 1] << "\" Source=\""
          << pieceSource(path, static_cast<int>(i)) << "\"/>\n";
    x << "  </PImageData>\n</VTKFile>\n";
    const std::string text = x.str();
    writeAtomically(path, [&](const fs::path& tmp) {
        std::ofstream out(tmp, std::ios::binary);
        out.write(text.data(), static_cast<std::streamsize>(text.size()));
        out.close();
        if (!out) UDVR_FILE_FAIL("cannot write " << path.string() << ": " << writeErrorText(errno));
    });
    // Pieces of an earlier write with more pieces, which this header no longer names.
    std::error_code ec;
    for (int i = static_cast<int>(boundaries.size()) - 1;; ++i) {
        const fs::path stale = path.parent_path() / pieceSource(path, i);
        if (!fs::remove(stale, ec)) break;
    }
}

void writeModelPvti(const fs::path& path, const ModelVolume& model, int pieces) {
    const std::vector<int> b = pvtiPieceBoundaries(model.grid.dims[2], pieces);
    // An earlier header goes first: a write stopped half-way leaves no .pvti that would name a
    // mix of old and new pieces.
    std::error_code ec;
    fs::remove(path, ec);
    for (std::size_t i = 0; i + 1 < b.size(); ++i)
        writeModelPvtiPiece(path, model, static_cast<int>(i), b[i], b[i + 1]);
    writeModelPvtiHeader(path, model, b);
}

ModelVolume readModelVti(const fs::path& path) {
    std::string note;
    ModelVolume m = detail::readModelVti(path, &note);
    detail::printNote(note);
    return m;
}

ModelVolume detail::readModelVti(const fs::path& path, std::string* geometryNote) {
    vtkSmartPointer<vtkImageData> image = readImageData(path);
    ModelVolume m;
    m.grid = gridOf(path, image, geometryNote);
    std::size_t n = m.voxelCount();
    vtkPointData* pd = image->GetPointData();
    vtkFieldData* fd = image->GetFieldData();

    // Reads array `name` with `components` per voxel (0 = any), NaN/Inf rejected.
    auto get = [&](const char* name, int components) -> std::vector<float> {
        vtkDataArray* a = pd->GetArray(name);
        if (a == nullptr) return {};
        int c = a->GetNumberOfComponents();
        if (components > 0 && c != components) {
            UDVR_FAIL(path.string() << ": array '" << name << "' has " << c
                                    << " components, expected " << components);
        }
        if (static_cast<std::size_t>(a->GetNumberOfTuples()) != n) {
            UDVR_FAIL(path.string()
                      << ": dims do not match the data: array '" << name << "' holds "
                      << a->GetNumberOfTuples() << " tuples, the grid " << n << " points");
        }
        std::vector<float> v = toFloat(path, a);
        try {
            detail::checkFinite(path, m.grid, v, c, std::string("array '") + name + "'");
        } catch (const UdvrError& e) {
            throw detail::ModelContentError(e.what());
        }
        return v;
    };
    m.mean = get("mean", 1);
    m.stddev = get("stddev", 1);
    m.min = get("min", 1);
    m.max = get("max", 1);
    m.iqr = get("iqr", 2);

    int q = getInt(path, fd, "quantile_count", 0);
    if (vtkDataArray* a = pd->GetArray("quantiles")) {
        if (q == 0) q = a->GetNumberOfComponents() - 1;
        if (q < 1) UDVR_FAIL(path.string() << ": array 'quantiles' needs at least 2 components");
        m.quantiles = get("quantiles", q + 1);
        m.quantileCount = q;
        m.quantileLevels = normalizedQuantileLevels(
            getDoubles(fd, "quantile_levels"), q, path.string() + ": field data 'quantile_levels'");
    }
    int k = getInt(path, fd, "gmm_components", 0);
    if (vtkDataArray* a = pd->GetArray("gmm")) {
        if (k == 0) k = a->GetNumberOfComponents() / 3;
        if (k < 1 || a->GetNumberOfComponents() != 3 * k) {
            UDVR_FAIL(path.string() << ": array 'gmm' has " << a->GetNumberOfComponents()
                                    << " components, expected 3K (pi, mu, sigma per component)");
        }
        m.gmm = get("gmm", 3 * k);
        m.gmmComponents = k;
    }
    if (m.mean.empty() && m.quantiles.empty() && m.gmm.empty() && m.iqr.empty() && m.min.empty()) {
        UDVR_FAIL(path.string() << ": no model arrays (mean, stddev, min, max, quantiles, iqr, "
                                   "gmm); arrays present: "
                                << arrayNames(pd));
    }

    m.density = getString(fd, "density", m.density);
    m.bandwidth = getDouble(fd, "bandwidth", 0.0);
    m.bandwidthRule = getString(fd, "bandwidth_rule", "");
    m.tailEps = getDouble(fd, "tail_eps", 0.0);
    m.samplesPerVoxel = getInt(path, fd, "samples_per_voxel", 0);
    m.downsample = getInt(path, fd, "downsample", 0);
    std::vector<double> bounds = getDoubles(fd, "bounds");
    if (bounds.empty()) {
        m.bounds = m.grid.bounds();
    } else if (bounds.size() == 6) {
        std::copy(bounds.begin(), bounds.end(), m.bounds.begin());
    } else {
        UDVR_FAIL(path.string() << ": field data 'bounds' holds " << bounds.size()
                                << " values, expected 6");
    }
    m.fullResMinSpacing = getDouble(fd, "full_res_min_spacing", m.grid.minSpacing());
    if (!(m.fullResMinSpacing > 0.0)) {
        UDVR_FAIL(path.string() << ": field data 'full_res_min_spacing' must be positive");
    }
    m.source = getString(fd, "source", "");
    m.defaultTf = getDoubles(fd, "default_tf");
    try {
        checkModelArrays(m, path.string());
        if (!m.defaultTf.empty()) decodeDefaultTfBasis(m.defaultTf, path.string());
    } catch (const UdvrError& e) {
        throw detail::ModelContentError(e.what());
    }
    return m;
}

}  // namespace udvr
