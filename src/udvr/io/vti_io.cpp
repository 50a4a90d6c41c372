// VTK XML ImageData (.vti): scalar fields and model volumes (SPEC §7). The VTK includes of the io
// module stay in this file and vti_check.cpp (what VTK's reader trusts, checked); VTK headers
// are heavy to compile.
#include <vtkCommand.h>
#include <vtkDataArray.h>
#include <vtkDataObject.h>
#include <vtkDoubleArray.h>
#include <vtkErrorCode.h>
#include <vtkFieldData.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkIntArray.h>
#include <vtkLogger.h>
#include <vtkMatrix3x3.h>
#include <vtkNew.h>
#include <vtkOutputWindow.h>
#include <vtkPointData.h>
#include <vtkSmartPointer.h>
#include <vtkStreamingDemandDrivenPipeline.h>
#include <vtkStringArray.h>
#include <vtkXMLImageDataWriter.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "udvr/io/field_io.h"
#include "udvr/io/io_detail.h"
#include "udvr/io/model_io.h"
#include "udvr/io/transfer_function_2d_io.h"
#include "udvr/io/vti_check.h"
#include "udvr/util/atomic_file.h"
#include "udvr/util/check.h"

namespace udvr {
namespace fs = std::filesystem;

namespace {

/// Collects the errors a VTK object reports, so they become one UdvrError line instead of text
/// on VTK's output window.
class ErrorCollector : public vtkCommand {
  public:
    static ErrorCollector* New() { return new ErrorCollector; }
    void Execute(vtkObject*, unsigned long, void* callData) override {
        ++count;
        if (!message.empty() || callData == nullptr) return;
        // VTK passes "ERROR: In file, line N\nClass (0x…): text\n\n"; keep the text.
        std::string text = static_cast<const char*>(callData);
        std::size_t nl = text.find('\n');
        if (nl != std::string::npos) text = text.substr(nl + 1);
        std::size_t cls = text.find("): ");
        if (cls != std::string::npos) text = text.substr(cls + 3);
        std::replace(text.begin(), text.end(), '\n', ' ');
        while (!text.empty() && text.back() == ' ') text.pop_back();
        message = text;
    }
    int count = 0;
    std::string message;
};

/// VTK's objects report errors on the output window (the XML parser, the pipeline executive,
/// the compressors: a dozen log lines on stderr for one bad file) besides the observers of the
/// reader; the reader's error, collected, is the one line to show. Called before any VTK use.
void silenceVtk() {
    static const bool silenced = [] {
        vtkOutputWindow::GetInstance()->SetDisplayModeToNever();
        vtkLogger::SetStderrVerbosity(vtkLogger::VERBOSITY_OFF);
        return true;
    }();
    (void)silenced;
}

/// A reader of `path` with its errors collected; fails unless VTK says it can read the file.
vtkSmartPointer<detail::CheckedVtiReader> newReader(const fs::path& path, ErrorCollector* errors) {
    silenceVtk();
    detail::requireFile(path);
    auto reader = vtkSmartPointer<detail::CheckedVtiReader>::New();
    reader->AddObserver(vtkCommand::ErrorEvent, errors);
    reader->AddObserver(vtkCommand::WarningEvent, errors);
    const std::string name = path.string();
    if (!reader->CanReadFile(name.c_str()))
        UDVR_FAIL(name << ": not a VTK XML ImageData file (expected <VTKFile type=\"ImageData\">)");
    reader->SetFileName(name.c_str());
    return reader;
}

/// Throws for a read that went wrong: what the checks found (vti_check.h), else VTK's first
/// error.
void throwIfFailed(const fs::path& path, detail::CheckedVtiReader* reader,
                   const ErrorCollector* errors, bool failed) {
    if (!reader->problem().empty()) UDVR_FAIL(path.string() << ": " << reader->problem());
    if (failed || errors->count > 0 || reader->GetErrorCode() != 0)
        UDVR_FAIL(path.string() << ": cannot read VTK ImageData"
                                << (errors->message.empty() ? "" : ": ") << errors->message
                                << " (truncated or corrupt file?)");
}

/// Read a VTK ImageData file; with maxPoints > 0, a whole extent of more points is refused from
/// the header, before any data is allocated.
vtkSmartPointer<vtkImageData> readImageData(const fs::path& path, double maxPoints = 0) {
    vtkNew<ErrorCollector> errors;
    auto reader = newReader(path, errors);
    const std::string name = path.string();
    if (maxPoints > 0) {
        reader->UpdateInformation();
        throwIfFailed(path, reader, errors, false);
        const int* e =
            reader->GetOutputInformation(0)->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT());
        double points = 1;
        for (int a = 0; a < 3 && e; ++a) points *= static_cast<double>(e[2 * a + 1]) - e[2 * a] + 1;
        if (e && points > maxPoints)
            UDVR_FAIL(name << ": extent " << e[0] << " " << e[1] << " " << e[2] << " " << e[3]
                           << " " << e[4] << " " << e[5] << " has more than " << maxPoints
                           << " points");
    }
    reader->Update();
    vtkImageData* image = reader->GetOutput();
    throwIfFailed(path, reader, errors, image == nullptr);
    vtkSmartPointer<vtkImageData> out = image;
    return out;
}

/// The image's grid; a Direction other than the identity is ignored, which *note (when given)
/// says, for the caller to print once the whole read succeeded.
Grid3 gridOf(const fs::path& path, vtkImageData* image, std::string* note) {
    Grid3 g;
    int extent[6];
    double origin[3], spacing[3];
    image->GetExtent(extent);
    image->GetOrigin(origin);
    image->GetSpacing(spacing);
    for (int a = 0; a < 3; ++a) {
        g.dims[a] = extent[2 * a + 1] - extent[2 * a] + 1;
        if (g.dims[a] < 1) UDVR_FAIL(path.string() << ": empty ImageData extent");
        if (!(spacing[a] > 0.0) || !std::isfinite(spacing[a])) {
            UDVR_FAIL(path.string() << ": spacing along axis " << a << " is " << spacing[a]
                                    << ", expected a positive number");
        }
        g.spacing[a] = spacing[a];
        // The point at index 0 of our grid is the extent's first point.
        g.origin[a] = origin[a] + extent[2 * a] * spacing[a];
    }
    if (vtkMatrix3x3* dir = image->GetDirectionMatrix();
        dir != nullptr && !dir->IsIdentity() && note != nullptr) {
        *note = "udvr: note: " + path.string() +
                ": the ImageData Direction is not the identity; ignoring the orientation";
    }
    return g;
}

/// A VTK data type as uint8 … float64 (ArrayInfo::type, ScalarField::valueType).
std::string vtkTypeName(int type) {
    switch (type) {
        case VTK_UNSIGNED_CHAR:
            return "uint8";
        case VTK_SIGNED_CHAR:
        case VTK_CHAR:
            return "int8";
        case VTK_UNSIGNED_SHORT:
            return "uint16";
        case VTK_SHORT:
            return "int16";
        case VTK_UNSIGNED_INT:
            return "uint32";
        case VTK_INT:
            return "int32";
        case VTK_FLOAT:
            return "float32";
        case VTK_DOUBLE:
            return "float64";
        default:
            return "VTK type " + std::to_string(type);
    }
}

template <class T>
void convertValues(const T* src, std::size_t n, float* dst) {
    for (std::size_t i = 0; i < n; ++i) dst[i] = static_cast<float>(src[i]);
}

/// All tuples × components of a numeric array as float.
std::vector<float> toFloat(const fs::path& path, vtkDataArray* array) {
    std::size_t n = static_cast<std::size_t>(array->GetNumberOfValues());
    std::vector<float> out(n);
    if (n == 0) return out;
    void* raw = array->GetVoidPointer(0);
    switch (array->GetDataType()) {
        vtkTemplateMacro(convertValues(static_cast<const VTK_TT*>(raw), n, out.data()));
        default:
            UDVR_FAIL(path.string() << ": array '" << (array->GetName() ? array->GetName() : "")
                                    << "' has unsupported type " << array->GetDataTypeAsString());
    }
    return out;
}

std::string arrayNames(vtkPointData* pd) {
    std::string names;
    for (int i = 0; i < pd->GetNumberOfArrays(); ++i) {
        const char* n = pd->GetArrayName(i);
        names += (i ? ", " : "");
        names += n ? n : "(unnamed)";
    }
    return names.empty() ? "none" : names;
}

/// Let VTK see our floats without a copy; the writer only reads them.
vtkSmartPointer<vtkFloatArray> wrapFloats(const std::vector<float>& values, int components,
                                          const char* name) {
    auto array = vtkSmartPointer<vtkFloatArray>::New();
    array->SetName(name);
    array->SetNumberOfComponents(components);
    array->SetArray(const_cast<float*>(values.data()), static_cast<vtkIdType>(values.size()),
                    /*save=*/1);
    return array;
}

vtkSmartPointer<vtkImageData> makeImage(const Grid3& grid) {
    auto image = vtkSmartPointer<vtkImageData>::New();
    image->SetDimensions(grid.dims[0], grid.dims[1], grid.dims[2]);
    image->SetOrigin(grid.origin[0], grid.origin[1], grid.origin[2]);
    image->SetSpacing(grid.spacing[0], grid.spacing[1], grid.spacing[2]);
    return image;
}

/// Block compression of appended data. Both are read by VTK ≥ 8.1 and ParaView ≥ 5.5.
enum class Compression {
    Zlib,  // ParaView's default; best ratio on smooth fields
    Lz4,   // model files: on float statistics zlib (level 5) saves ~10 % of the size at ~20×
           // the time (64³ model, 26 MB: 0.62 s vs 0.03 s to write; 0.11 s vs 0.01 s to read)
};

/// Binary appended, block-compressed, 64-bit headers: ParaView's default kind of .vti.
void writeImageData(const fs::path& path, vtkImageData* image,
                    Compression compression = Compression::Zlib) {
    silenceVtk();
    writeAtomically(path, [&](const fs::path& tmp) {
        vtkNew<vtkXMLImageDataWriter> writer;
        vtkNew<ErrorCollector> errors;
        writer->AddObserver(vtkCommand::ErrorEvent, errors);
        std::string name = tmp.string();
        writer->SetFileName(name.c_str());
        writer->SetInputData(image);
        writer->SetDataModeToAppended();
        writer->EncodeAppendedDataOff();
        if (compression == Compression::Lz4)
            writer->SetCompressorTypeToLZ4();
        else
            writer->SetCompressorTypeToZLib();
        writer->SetHeaderTypeToUInt64();
        errno = 0;
        const int ok = writer->Write();
        const int err = errno;  // the failed open or write (VTK's message names the temporary)
        if (ok != 1 || errors->count > 0 || writer->GetErrorCode() != 0) {
            std::string why = writeErrorText(err);
            if (why.empty()) why = errors->message;
            if (why.empty())
                why = writer->GetErrorCode() == vtkErrorCode::OutOfDiskSpaceError
                          ? std::string("out of disk space")
                          : "VTK error code " + std::to_string(writer->GetErrorCode());
            UDVR_FILE_FAIL("cannot write " << path.string() << ": " << why);
        }
    });
}

// ---- model field data ----------------------------------------------------------------------

void addDouble(vtkFieldData* fd, const char* name, std::vector<double> values) {
    vtkNew<vtkDoubleArray> a;
    a->SetName(name);
    for (double v : values) a->InsertNextValue(v);
    fd->AddArray(a);
}

void addInt(vtkFieldData* fd, const char* name, int value) {
    vtkNew<vtkIntArray> a;
    a->SetName(name);
    a->InsertNextValue(value);
    fd->AddArray(a);
}

void addString(vtkFieldData* fd, const char* name, const std::string& value) {
    vtkNew<vtkStringArray> a;
    a->SetName(name);
    a->InsertNextValue(value);
    fd->AddArray(a);
}

std::vector<double> getDoubles(vtkFieldData* fd, const char* name) {
    std::vector<double> out;
    auto* a = vtkDataArray::SafeDownCast(fd ? fd->GetAbstractArray(name) : nullptr);
    if (a == nullptr) return out;
    for (vtkIdType i = 0; i < a->GetNumberOfValues(); ++i) {
        out.push_back(a->GetComponent(i / a->GetNumberOfComponents(),
                                      static_cast<int>(i % a->GetNumberOfComponents())));
    }
    return out;
}

double getDouble(vtkFieldData* fd, const char* name, double fallback) {
    auto v = getDoubles(fd, name);
    return v.empty() ? fallback : v[0];
}

int getInt(const fs::path& path, vtkFieldData* fd, const char* name, int fallback) {
    double v = getDouble(fd, name, fallback);
    if (!std::isfinite(v) || v != std::floor(v) || std::abs(v) > 1e9) {
        UDVR_FAIL(path.string() << ": field data '" << name << "' is " << v
                                << ", expected an integer");
    }
    return static_cast<int>(v);
}

std::string getString(vtkFieldData* fd, const char* name, const std::string& fallback) {
    auto* a = vtkStringArray::SafeDownCast(fd ? fd->GetAbstractArray(name) : nullptr);
    if (a == nullptr || a->GetNumberOfValues() == 0) return fallback;
    return a->GetValue(0);
}

}  // namespace

// ---- fields ------------------------------------------------------------------------------------

ScalarField detail::readFieldVti(const fs::path& path, const std::string& var,
                                 std::string* geometryNote) {
    vtkSmartPointer<vtkImageData> image = readImageData(path);
    ScalarField f;
    f.grid = gridOf(path, image, geometryNote);
    vtkPointData* pd = image->GetPointData();
    vtkDataArray* array = nullptr;
    if (!var.empty()) {
        array = pd->GetArray(var.c_str());
        if (array == nullptr) {
            UDVR_FAIL(path.string()
                      << ": no point array '" << var << "' (arrays: " << arrayNames(pd) << ")");
        }
    } else {
        array = pd->GetScalars();
        if (array == nullptr && pd->GetNumberOfArrays() > 0) array = pd->GetArray(0);
        if (array == nullptr) UDVR_FAIL(path.string() << ": no numeric point data array");
    }
    std::string name = array->GetName() ? array->GetName() : "";
    if (array->GetNumberOfComponents() != 1) {
        UDVR_FAIL(path.string() << ": point array '" << name << "' has "
                                << array->GetNumberOfComponents()
                                << " components, expected a scalar (1 component)");
    }
    if (static_cast<std::size_t>(array->GetNumberOfTuples()) != f.grid.pointCount()) {
        UDVR_FAIL(path.string() << ": dims do not match the data: array '" << name << "' holds "
                                << array->GetNumberOfTuples() << " values, the grid "
                                << f.grid.pointCount());
    }
    f.values = toFloat(path, array);
    f.name = name;
    f.valueType = vtkTypeName(array->GetDataType());
    // Every numeric VTK type but these two holds integers.
    const bool floating = array->GetDataType() == VTK_FLOAT || array->GetDataType() == VTK_DOUBLE;
    f.valueStep = floating ? 0.0 : 1.0;
    return f;
}

void writeFieldVti(const fs::path& path, const ScalarField& field) {
    UDVR_CHECK_MSG(field.values.size() == field.grid.pointCount(), "field size vs grid");
    auto image = makeImage(field.grid);
    auto array = wrapFloats(field.values, 1, field.name.empty() ? "scalars" : field.name.c_str());
    image->GetPointData()->SetScalars(array);
    writeImageData(path, image);
}

// ---- models ------------------------------------------------------------------------------------

void writeModelVti(const fs::path& path, const ModelVolume& model) {
    std::size_t n = model.voxelCount();
    auto image = makeImage(model.grid);
    vtkPointData* pd = image->GetPointData();
    auto add = [&](const std::vector<float>& values, int components, const char* name) {
        if (values.empty()) return;
        UDVR_CHECK_MSG(values.size() == n * static_cast<std::size_t>(components),
                       std::string("model array size: ") + name);
        pd->AddArray(wrapFloats(values, components, name));
    };
    add(model.mean, 1, "mean");
    add(model.stddev, 1, "stddev");
    add(model.min, 1, "min");
    add(model.max, 1, "max");
    if (model.hasQuantiles()) add(model.quantiles, model.quantileCount + 1, "quantiles");
    add(model.iqr, 2, "iqr");
    if (model.hasGmm()) add(model.gmm, 3 * model.gmmComponents, "gmm");
    if (!model.mean.empty()) pd->SetActiveScalars("mean");

    vtkFieldData* fd = image->GetFieldData();
    addInt(fd, "quantile_count", model.hasQuantiles() ? model.quantileCount : 0);
    if (model.hasQuantiles()) {
        std::vector<double> levels(static_cast<std::size_t>(model.quantileCount) + 1);
        for (int j = 0; j <= model.quantileCount; ++j)
            levels[static_cast<std::size_t>(j)] = model.quantileLevel(j);
        addDouble(fd, "quantile_levels", levels);
    }
    addString(fd, "density", model.density);
    addDouble(fd, "bandwidth", {model.bandwidth});
    addString(fd, "bandwidth_rule", model.bandwidthRule);
    addDouble(fd, "tail_eps", {model.tailEps});
    addInt(fd, "samples_per_voxel", model.samplesPerVoxel);
    addInt(fd, "downsample", model.downsample);
    addDouble(fd, "bounds", std::vector<double>(model.bounds.begin(), model.bounds.end()));
    addDouble(fd, "full_res_min_spacing", {model.fullResMinSpacing});
    addInt(fd, "gmm_components", model.hasGmm() ? model.gmmComponents : 0);
    addString(fd, "source", model.source);
    writeImageData(path, image, Compression::Lz4);
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
        detail::checkFinite(path, m.grid, v, c, std::string("array '") + name + "'");
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
    return m;
}

// ---- 2D transfer functions (SPEC §9) -----------------------------------------------------------

TransferFunction2D detail::readTransferFunction2DVti(const fs::path& path) {
    vtkSmartPointer<vtkImageData> image =
        readImageData(path, static_cast<double>(kMaxTf2Resolution) * kMaxTf2Resolution);
    const std::string name = path.string();
    int extent[6];
    double origin[3], spacing[3];
    image->GetExtent(extent);
    image->GetOrigin(origin);
    image->GetSpacing(spacing);
    const int w = extent[1] - extent[0] + 1, h = extent[3] - extent[2] + 1;
    const int d = extent[5] - extent[4] + 1;
    if (d != 1 || w < 2 || h < 2)
        UDVR_FAIL(name << ": a 2D transfer function needs W x H x 1 points with W, H >= 2, got "
                       << w << "x" << h << "x" << d);
    for (int a = 0; a < 2; ++a)
        if (!(spacing[a] > 0.0) || !std::isfinite(spacing[a]) || !std::isfinite(origin[a]))
            UDVR_FAIL(name << ": spacing along " << (a == 0 ? "x" : "y") << " is " << spacing[a]
                           << " (origin " << origin[a] << "), expected a positive number");

    // The active scalars when they are RGBA, else the first 4-component point array.
    vtkPointData* pd = image->GetPointData();
    vtkDataArray* array = pd->GetScalars();
    if (array == nullptr || array->GetNumberOfComponents() != 4) {
        array = nullptr;
        for (int i = 0; i < pd->GetNumberOfArrays() && array == nullptr; ++i) {
            vtkDataArray* a = pd->GetArray(i);
            if (a != nullptr && a->GetNumberOfComponents() == 4) array = a;
        }
    }
    if (array == nullptr)
        UDVR_FAIL(name << ": no 4-component (r, g, b, alpha) point array (arrays: "
                       << arrayNames(pd) << ")");
    const std::string arrayName = array->GetName() ? array->GetName() : "";
    if (array->GetDataType() != VTK_FLOAT && array->GetDataType() != VTK_DOUBLE)
        UDVR_FAIL(name << ": point array '" << arrayName << "' is " << array->GetDataTypeAsString()
                       << ", expected float or double");
    if (static_cast<std::size_t>(array->GetNumberOfTuples()) != static_cast<std::size_t>(w) * h)
        UDVR_FAIL(name << ": dims do not match the data: array '" << arrayName << "' holds "
                       << array->GetNumberOfTuples() << " tuples, the grid " << w * h << " points");

    TransferFunction2D tf;
    tf.width = w;
    tf.height = h;
    tf.rgba = toFloat(path, array);
    for (std::size_t k = 0; k < tf.rgba.size(); ++k)
        if (!std::isfinite(tf.rgba[k]))
            UDVR_FAIL(name << ": non-finite value in array '" << arrayName << "' at point ("
                           << k / 4 % static_cast<std::size_t>(w) << ","
                           << k / 4 / static_cast<std::size_t>(w)
                           << "); expected values in [0, 1]");
    tf.x0 = origin[0] + extent[0] * spacing[0];
    tf.x1 = tf.x0 + (w - 1) * spacing[0];
    tf.y0 = origin[1] + extent[2] * spacing[1];
    tf.y1 = tf.y0 + (h - 1) * spacing[1];
    // udvr's own files also hold the exact domain (origin + (W−1)·spacing may differ from x1 in
    // the last bits); it is used only where it agrees with the geometry.
    const std::vector<double> exact = getDoubles(image->GetFieldData(), "tf2_domain");
    if (exact.size() == 4) {
        const double tolX = 1e-6 * spacing[0], tolY = 1e-6 * spacing[1];
        if (std::abs(exact[0] - tf.x0) <= tolX && std::abs(exact[1] - tf.x1) <= tolX &&
            std::abs(exact[2] - tf.y0) <= tolY && std::abs(exact[3] - tf.y1) <= tolY) {
            tf.x0 = exact[0];
            tf.x1 = exact[1];
            tf.y0 = exact[2];
            tf.y1 = exact[3];
        }
    }
    try {
        tf.validate();
    } catch (const UdvrError& e) {
        UDVR_FAIL(name << ": " << e.what());
    }
    return tf;
}

void writeTransferFunction2DVti(const fs::path& path, const TransferFunction2D& tf) {
    tf.validate();
    auto image = vtkSmartPointer<vtkImageData>::New();
    image->SetDimensions(tf.width, tf.height, 1);
    image->SetOrigin(tf.x0, tf.y0, 0.0);
    image->SetSpacing((tf.x1 - tf.x0) / (tf.width - 1), (tf.y1 - tf.y0) / (tf.height - 1), 1.0);
    image->GetPointData()->SetScalars(wrapFloats(tf.rgba, 4, "tf2"));
    addDouble(image->GetFieldData(), "tf2_domain", {tf.x0, tf.x1, tf.y0, tf.y1});
    writeImageData(path, image);
}

std::vector<ArrayInfo> detail::listArraysVti(const fs::path& path) {
    // The header only: the reader's pipeline information names each point array, its type and
    // components without reading the data (a model's arrays can be gigabytes).
    vtkNew<ErrorCollector> errors;
    auto reader = newReader(path, errors);
    reader->UpdateInformation();
    throwIfFailed(path, reader, errors, false);
    vtkInformationVector* arraysInfo =
        reader->GetOutputInformation(0)->Get(vtkDataObject::POINT_DATA_VECTOR());
    std::vector<ArrayInfo> arrays;
    for (int i = 0; arraysInfo != nullptr && i < arraysInfo->GetNumberOfInformationObjects(); ++i) {
        vtkInformation* info = arraysInfo->GetInformationObject(i);
        ArrayInfo a;
        a.name = info->Has(vtkDataObject::FIELD_NAME()) ? info->Get(vtkDataObject::FIELD_NAME())
                                                        : "(unnamed)";
        a.components = info->Has(vtkDataObject::FIELD_NUMBER_OF_COMPONENTS())
                           ? info->Get(vtkDataObject::FIELD_NUMBER_OF_COMPONENTS())
                           : 1;
        const int type = info->Get(vtkDataObject::FIELD_ARRAY_TYPE());
        if (type == VTK_STRING) continue;  // not a numeric array
        a.type = vtkTypeName(type);
        arrays.push_back(a);
    }
    return arrays;
}

ModelVolume readModelOrField(const fs::path& path, const FieldReadOptions& options) {
    if (detail::lowerExtension(path) == ".vti" && options.var.empty()) {
        std::string modelError;
        try {
            std::string note;
            ModelVolume m = detail::readModelVti(path, &note);
            if (!m.mean.empty()) {
                detail::printNote(note);
                return m;
            }
            modelError = path.string() + " has no 'mean' array";
        } catch (const UdvrError& e) {
            modelError = e.what();
        }
        try {
            return modelFromField(readField(path, options));
        } catch (const UdvrError& e) {
            // Both readers open the file the same way: a missing, truncated or corrupt file
            // fails both for one reason, which is said once (as the error it was: a FileError
            // stays one).
            if (modelError == e.what()) throw;
            UDVR_FAIL(path.string() << " is neither a model (" << modelError << ") nor a field ("
                                    << e.what() << ")");
        }
    }
    return modelFromField(readField(path, options));
}

}  // namespace udvr
