#include "vtkUdvrVolumeMapper.h"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <span>
#include <sstream>
#include <string>
#include <vector>

#include "udvr/classify/model_kind.h"
#include "udvr/classify/transfer_function.h"
#include "udvr/classify/transfer_function_2d.h"
#include "udvr/classify/transfer_function_2d_widget_json.h"
#include "udvr/render/render.h"
#include "udvr/stats/model_view.h"
#include "udvr/stats/model_volume.h"
#include "udvr/util/check.h"
#include "vtkAlgorithm.h"
#include "vtkCamera.h"
#include "vtkColorTransferFunction.h"
#include "vtkDataArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkMatrix3x3.h"
#include "vtkObjectFactory.h"
#include "vtkOpenGLRenderWindow.h"
#include "vtkOpenGLState.h"
#include "vtkPiecewiseFunction.h"
#include "vtkPointData.h"
#include "vtkRenderer.h"
#include "vtkSmartPointer.h"
#include "vtkStringArray.h"
#include "vtkVolume.h"
#include "vtkVolumeProperty.h"
#include "vtkXMLImageDataReader.h"
#include "vtk_glew.h"

namespace {

// Control points sampled from ParaView's functions where they are not piecewise linear in RGB
// (another colour space, midpoints or sharpness, log scale).
constexpr int kSampledPoints = 1024;

double fieldDouble(vtkFieldData* fd, const char* name, double fallback) {
    vtkDataArray* a = fd ? fd->GetArray(name) : nullptr;
    return a && a->GetNumberOfTuples() * a->GetNumberOfComponents() >= 1 ? a->GetComponent(0, 0)
                                                                         : fallback;
}

std::vector<double> fieldDoubles(vtkFieldData* fd, const char* name) {
    std::vector<double> v;
    vtkDataArray* a = fd ? fd->GetArray(name) : nullptr;
    if (!a) return v;
    const vtkIdType n = a->GetNumberOfTuples() * a->GetNumberOfComponents();
    for (vtkIdType i = 0; i < n; ++i)
        v.push_back(a->GetComponent(i / a->GetNumberOfComponents(),
                                    static_cast<int>(i % a->GetNumberOfComponents())));
    return v;
}

std::string fieldString(vtkFieldData* fd, const char* name, const std::string& fallback) {
    auto* a = fd ? vtkStringArray::SafeDownCast(fd->GetAbstractArray(name)) : nullptr;
    return a && a->GetNumberOfValues() >= 1 ? a->GetValue(0) : fallback;
}

std::string arrayNames(vtkPointData* pd) {
    std::string names;
    for (int i = 0; i < pd->GetNumberOfArrays(); ++i) {
        const char* n = pd->GetArrayName(i);
        names += (i ? ", " : "") + std::string(n ? n : "(unnamed)");
    }
    return names.empty() ? "none" : names;
}

bool isModelArray(const std::string& name) {
    for (const udvr::ModelFileArray& a : udvr::kModelFileArrays)
        if (name == a.name) return true;
    return false;
}

// The model a rank holds (SPEC §7 arrays and field data) from its piece of image data: a view
// of VTK's float arrays, which `held` keeps alive (nothing copied), and arrays of other types
// converted into `converted`, which also holds the field data the view points to (view.h's
// lifetime contract). Filled in place: the view points into this object.
struct PieceModel {
    udvr::ModelVolume converted;
    std::vector<vtkSmartPointer<vtkDataArray>> held;
    udvr::ModelView view;
    std::size_t copiedBytes = 0;
};

// Grid from the extent, origin and spacing; `whole` is the extent of the data the piece belongs
// to.
void modelOf(vtkImageData* image, const int whole[6], PieceModel& out) {
    out = PieceModel{};
    udvr::ModelVolume& m = out.converted;
    int ext[6];
    image->GetExtent(ext);
    const double* origin = image->GetOrigin();
    const double* spacing = image->GetSpacing();
    const double* dir = image->GetDirectionMatrix()->GetData();
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            if (dir[3 * r + c] != (r == c ? 1.0 : 0.0))
                UDVR_FAIL(
                    "the image has a direction matrix other than the identity; udvr renders "
                    "axis-aligned grids");
    for (int a = 0; a < 3; ++a) {
        m.grid.dims[a] = ext[2 * a + 1] - ext[2 * a] + 1;
        m.grid.spacing[a] = spacing[a];
        m.grid.origin[a] = origin[a] + ext[2 * a] * spacing[a];
        if (m.grid.dims[a] < 1) UDVR_FAIL("the image is empty");
    }
    const std::size_t n = m.voxelCount();
    vtkPointData* pd = image->GetPointData();
    vtkFieldData* fd = image->GetFieldData();
    const int qField = static_cast<int>(fieldDouble(fd, "quantile_count", 0));
    const int kField = static_cast<int>(fieldDouble(fd, "gmm_components", 0));
    std::vector<std::pair<const udvr::ModelFileArray*, std::span<const float>>> borrowed;
    for (const udvr::ModelFileArray& spec : udvr::kModelFileArrays) {
        vtkDataArray* a = pd->GetArray(spec.name);
        if (!a) continue;
        const int c = a->GetNumberOfComponents();
        int expected = spec.floatsPerVoxel(qField, kField);
        if (spec.arity == udvr::ModelFileArray::Arity::Quantiles) {
            if (c < 2) UDVR_FAIL("array 'quantiles' needs at least 2 components, it has " << c);
            m.quantileCount = c - 1;
            expected = c;
        } else if (spec.arity == udvr::ModelFileArray::Arity::Gmm) {
            if (c < 3 || c % 3 != 0)
                UDVR_FAIL("array 'gmm' has " << c
                                             << " components, expected 3K (pi, mu, sigma each)");
            m.gmmComponents = c / 3;
            expected = c;
        }
        if (c != expected)
            UDVR_FAIL("array '" << spec.name << "' has " << c << " components, expected "
                                << expected);
        if (static_cast<std::size_t>(a->GetNumberOfTuples()) != n)
            UDVR_FAIL("array '" << spec.name << "' holds " << a->GetNumberOfTuples()
                                << " tuples, the grid " << n << " points");
        const std::size_t count = n * static_cast<std::size_t>(c);
        // vtkFloatArray is VTK's contiguous (array-of-structs) float array: borrowed as it is.
        if (auto* f = vtkFloatArray::SafeDownCast(a)) {
            out.held.emplace_back(a);
            borrowed.emplace_back(&spec, std::span<const float>(f->GetPointer(0), count));
            continue;
        }
        std::vector<float>& values = m.*spec.values;
        values.resize(count);
        for (std::size_t i = 0; i < count; ++i)
            values[i] = static_cast<float>(
                a->GetComponent(static_cast<vtkIdType>(i / c), static_cast<int>(i % c)));
        out.copiedBytes += count * sizeof(float);
    }
    if (m.quantileCount > 0)
        m.quantileLevels = udvr::normalizedQuantileLevels(
            fieldDoubles(fd, "quantile_levels"), m.quantileCount, "field data 'quantile_levels'");
    m.density = fieldString(fd, "density", m.density);
    m.samplesPerVoxel = static_cast<int>(fieldDouble(fd, "samples_per_voxel", 0));
    m.downsample = static_cast<int>(fieldDouble(fd, "downsample", 0));
    const std::vector<double> bounds = fieldDoubles(fd, "bounds");
    if (bounds.size() == 6)
        std::copy(bounds.begin(), bounds.end(), m.bounds.begin());
    else
        for (int a = 0; a < 3; ++a)  // the whole grid's box
        {
            m.bounds[2 * a] = origin[a] + whole[2 * a] * spacing[a];
            m.bounds[2 * a + 1] = origin[a] + whole[2 * a + 1] * spacing[a];
        }
    m.fullResMinSpacing = fieldDouble(fd, "full_res_min_spacing", m.grid.minSpacing());
    if (!(m.fullResMinSpacing > 0.0))
        UDVR_FAIL("field data 'full_res_min_spacing' must be positive");
    out.view = udvr::ModelView(m);
    for (const auto& [spec, values] : borrowed) out.view.array(*spec) = values;
    const udvr::ModelView& v = out.view;
    if (v.mean.empty() && v.quantiles.empty() && v.gmm.empty() && v.iqr.empty() && v.min.empty())
        UDVR_FAIL(
            "the data holds no udvr model arrays (mean, stddev, min, max, quantiles, iqr, "
            "gmm; written by `udvr build`); its point arrays: "
            << arrayNames(pd));
    udvr::checkModelArrays(v, "the model");
}

// Passes one of ParaView's functions to emit(x, values): its nodes (x, Channels values, midpoint,
// sharpness) where `linear` holds and every node has midpoint 0.5 and sharpness 0 (piecewise
// linear, as udvr's TF JSON), else kSampledPoints samples of sample(x, values) over `range` (what
// ParaView shows in its editor).
template <int Channels, class Node, class Sample, class Emit>
void functionPoints(bool linear, int size, const Node& node, const double range[2],
                    const Sample& sample, const Emit& emit) {
    std::vector<std::array<double, Channels + 3>> nodes(static_cast<std::size_t>(size));
    for (auto& n : nodes) {
        node(static_cast<int>(&n - nodes.data()), n.data());
        linear = linear && n[Channels + 1] == 0.5 && n[Channels + 2] == 0.0;
    }
    if (linear) {
        for (const auto& n : nodes) emit(n[0], n.data() + 1);
        return;
    }
    for (int i = 0; i < kSampledPoints; ++i) {
        const double x = range[0] + (range[1] - range[0]) * i / (kSampledPoints - 1);
        double v[Channels];
        sample(x, v);
        emit(x, v);
    }
}

// ParaView's lookup table and scalar opacity function as udvr's 1D TF (functionPoints).
udvr::TransferFunction1D tfOf(vtkColorTransferFunction* ctf, vtkPiecewiseFunction* pwf) {
    if (!ctf || ctf->GetSize() < 1)
        UDVR_FAIL("no colour map: colour the representation by a model array (e.g. 'mean')");
    if (!pwf || pwf->GetSize() < 1) UDVR_FAIL("no scalar opacity function");
    udvr::TransferFunction1D tf;
    double range[2];
    ctf->GetRange(range);
    functionPoints<3>(
        ctf->GetColorSpace() == VTK_CTF_RGB && ctf->GetScale() == VTK_CTF_LINEAR, ctf->GetSize(),
        [&](int i, double* node) { ctf->GetNodeValue(i, node); }, range,
        [&](double x, double* rgb) { ctf->GetColor(x, rgb); },
        [&](double x, const double* rgb) {
            tf.colorX.push_back(x);
            tf.color.push_back({rgb[0], rgb[1], rgb[2]});
        });
    pwf->GetRange(range);
    functionPoints<1>(
        true, pwf->GetSize(), [&](int i, double* node) { pwf->GetNodeValue(i, node); }, range,
        [&](double x, double* alpha) { *alpha = pwf->GetValue(x); },
        [&](double x, const double* alpha) {
            tf.opacityX.push_back(x);
            tf.opacity.push_back(std::clamp(*alpha, 0.0, 1.0));
        });
    tf.validate();
    return tf;
}

// A 2D TF from a raster image: W×H×1 points of RGBA `a`; the domain from `range` (x0, x1, y0,
// y1: ParaView's 2D TF, texel centres) or else from the image's origin and spacing, or field data
// tf2_domain (udvr tf2's exact domain).
udvr::TransferFunction2D tf2OfRaster(vtkImageData* img, vtkDataArray* a, const double* range) {
    int dims[3];
    img->GetDimensions(dims);
    udvr::TransferFunction2D tf;
    tf.width = dims[0];
    tf.height = dims[1];
    const double* o = img->GetOrigin();
    const double* s = img->GetSpacing();
    int ext[6];
    img->GetExtent(ext);
    tf.x0 = o[0] + ext[0] * s[0];
    tf.x1 = tf.x0 + (dims[0] - 1) * s[0];
    tf.y0 = o[1] + ext[2] * s[1];
    tf.y1 = tf.y0 + (dims[1] - 1) * s[1];
    vtkDataArray* exact = img->GetFieldData()->GetArray("tf2_domain");
    if (range) {
        // ParaView's raster spans its range texel by texel, as VTK's GPU mapper samples it: texel i
        // at its centre, range[0] + (i + ½)·(range[1] − range[0])/W, clamped beyond the outer ones.
        const double dx = (range[1] - range[0]) / tf.width, dy = (range[3] - range[2]) / tf.height;
        tf.x0 = range[0] + 0.5 * dx;
        tf.x1 = range[1] - 0.5 * dx;
        tf.y0 = range[2] + 0.5 * dy;
        tf.y1 = range[3] - 0.5 * dy;
    } else if (exact && exact->GetNumberOfTuples() * exact->GetNumberOfComponents() == 4) {
        tf.x0 = exact->GetComponent(0, 0);
        tf.x1 = exact->GetComponent(1, 0);
        tf.y0 = exact->GetComponent(2, 0);
        tf.y1 = exact->GetComponent(3, 0);
    }
    tf.rgba.resize(static_cast<std::size_t>(tf.width) * tf.height * 4);
    const double scale = a->GetDataType() == VTK_UNSIGNED_CHAR ? 1.0 / 255.0 : 1.0;
    for (std::size_t i = 0; i < tf.rgba.size(); ++i)
        tf.rgba[i] = static_cast<float>(
            scale * a->GetComponent(static_cast<vtkIdType>(i / 4), static_cast<int>(i % 4)));
    tf.validate();
    return tf;
}

// A 2D TF file (SPEC §9), as `udvr render --tf2` reads it: a raster .vti (W×H×1 points, a
// 4-component array r, g, b, α; x along i, y along j, the domain from origin and spacing), read
// with ParaView's own VTK; or a widget .json, parsed and rasterised by udvr's core (its domain
// and resolution from the file, else 256×256 points).
udvr::TransferFunction2D tf2Of(const std::string& path) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec))
        UDVR_FAIL("2D transfer function '" << path << "': no such file");
    std::string suffix = std::filesystem::path(path).extension().string();
    std::transform(suffix.begin(), suffix.end(), suffix.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (suffix == ".json") {
        std::ifstream in(path, std::ios::binary);
        std::ostringstream text;
        text << in.rdbuf();
        if (!in) UDVR_FAIL("2D transfer function '" << path << "': cannot read it");
        return udvr::transferFunction2DFromWidgets(text.str(), path);
    }
    if (suffix != ".vti")
        UDVR_FAIL("2D transfer function '"
                  << path
                  << "': expected a raster (.vti) or widgets (.json); make a raster of another "
                     "form with `udvr tf2 TF2 -o tf2.vti`");
    auto reader = vtkSmartPointer<vtkXMLImageDataReader>::New();
    if (!reader->CanReadFile(path.c_str()))
        UDVR_FAIL("2D transfer function '" << path << "': not a VTK XML image file");
    reader->SetFileName(path.c_str());
    reader->Update();
    vtkImageData* img = reader->GetOutput();
    vtkDataArray* a = nullptr;
    for (int i = 0; img && i < img->GetPointData()->GetNumberOfArrays(); ++i)
        if (img->GetPointData()->GetArray(i) &&
            img->GetPointData()->GetArray(i)->GetNumberOfComponents() == 4)
            a = img->GetPointData()->GetArray(i);
    int dims[3] = {0, 0, 0};
    if (img) img->GetDimensions(dims);
    if (!a || dims[2] != 1)
        UDVR_FAIL("2D transfer function '"
                  << path
                  << "': expected W x H x 1 points with a 4-component array (r, g, b, alpha)");
    return tf2OfRaster(img, a, nullptr);
}

std::size_t modelBytes(const udvr::ModelView& m) {
    std::size_t bytes = 0;
    for (const udvr::ModelFileArray& a : udvr::kModelFileArrays)
        bytes += m.array(a).size() * sizeof(float);
    return bytes;
}

// "VmRSS" or "VmHWM" of this process in MiB (Linux), or -1.
long statusMiB(const char* key) {
    std::FILE* f = std::fopen("/proc/self/status", "r");
    if (!f) return -1;
    char line[256];
    long kib = -1;
    const std::size_t n = std::strlen(key);
    while (std::fgets(line, sizeof line, f))
        if (std::strncmp(line, key, n) == 0 && line[n] == ':')
            kib = std::strtol(line + n + 1, nullptr, 10);
    std::fclose(f);
    return kib < 0 ? -1 : kib / 1024;
}

}  // namespace

struct vtkUdvrVolumeMapper::Internals {
    PieceModel model;
    vtkImageData* image = nullptr;  // what `model` was made from, and when
    vtkMTimeType imageTime = 0;
    int whole[6] = {0, -1, 0, -1, 0, -1};
    udvr::RenderCache cache;
    std::string tf2Path;
    std::filesystem::file_time_type tf2Time{};
    udvr::TransferFunction2D tf2;
    vtkSmartPointer<vtkImageData> pvTf2;  // ParaView's 2D TF raster, and its range
    double pvTf2Range[4] = {0, 0, 0, 0};
    vtkMTimeType pvTf2Time = 0;  // when `pvTf2Built` was made from it
    udvr::TransferFunction2D pvTf2Built;
    std::vector<float> pixels;  // the frame, rows bottom to top (OpenGL's order)
    std::string lastError;
};

vtkStandardNewMacro(vtkUdvrVolumeMapper);

vtkUdvrVolumeMapper::vtkUdvrVolumeMapper() : Impl(new Internals) {}

vtkUdvrVolumeMapper::~vtkUdvrVolumeMapper() {
    this->SetTransferFunction2DFile(nullptr);
    delete this->Impl;
}

void vtkUdvrVolumeMapper::Render(vtkRenderer* ren, vtkVolume* vol) {
    if (vtkAlgorithm* producer = this->GetInputAlgorithm()) producer->Update();
    vtkImageData* image = vtkImageData::SafeDownCast(this->GetInput());
    if (!image || image->GetNumberOfPoints() == 0) return;  // a rank without data
    Internals& in = *this->Impl;
    try {
        const char* colorArray = this->GetArrayName();
        if (!colorArray || !isModelArray(colorArray))
            UDVR_FAIL(
                "Uncertain Volume renders a udvr model: colour by one of its arrays (mean, "
                "stddev, min, max, quantiles, iqr, gmm), not '"
                << (colorArray ? colorArray : "") << "'");
        vtkMTimeType time = image->GetMTime();
        time = std::max(time, image->GetPointData()->GetMTime());
        if (in.image != image || in.imageTime != time ||
            !std::equal(in.whole, in.whole + 6, this->WholeExtent)) {
            // The cache is keyed by the arrays' addresses: cleared before they are released.
            in.cache.clear();
            in.image = nullptr;
            modelOf(image, this->WholeExtent, in.model);
            in.image = image;
            in.imageTime = time;
            std::copy(this->WholeExtent, this->WholeExtent + 6, in.whole);
            if (std::getenv("UDVR_PARAVIEW_VERBOSE")) {
                int e[6];
                image->GetExtent(e);
                std::fprintf(stderr,
                             "udvr: rendering extent %d..%d %d..%d %d..%d of %d..%d %d..%d %d..%d "
                             "(%zu voxels)\n",
                             e[0], e[1], e[2], e[3], e[4], e[5], in.whole[0], in.whole[1],
                             in.whole[2], in.whole[3], in.whole[4], in.whole[5],
                             in.model.view.voxelCount());
                const udvr::ModelView& v = in.model.view;
                std::fprintf(stderr,
                             "udvr: grid origin %g %g %g spacing %g %g %g; bounds %g %g %g %g %g "
                             "%g; full-res "
                             "spacing %g; q %d, K %d\n",
                             v.grid.origin[0], v.grid.origin[1], v.grid.origin[2],
                             v.grid.spacing[0], v.grid.spacing[1], v.grid.spacing[2], v.bounds[0],
                             v.bounds[1], v.bounds[2], v.bounds[3], v.bounds[4], v.bounds[5],
                             v.fullResMinSpacing, v.quantileCount, v.gmmComponents);
            }
        }
        const udvr::ModelView& m = in.model.view;

        udvr::RenderSettings s;
        int width = 0, height = 0, x0 = 0, y0 = 0;
        ren->GetTiledSizeAndOrigin(&width, &height, &x0, &y0);
        if (width < 1 || height < 1) return;
        s.width = width;
        s.height = height;
        vtkCamera* cam = ren->GetActiveCamera();
        cam->GetPosition(s.camera.position.data());
        cam->GetFocalPoint(s.camera.focalPoint.data());
        cam->GetViewUp(s.camera.viewUp.data());
        s.camera.viewAngleDeg = cam->GetViewAngle();
        s.camera.parallel = cam->GetParallelProjection() != 0;
        s.camera.parallelScale = cam->GetParallelScale();
        s.step = this->Step;
        s.unitDistance = this->UnitDistance;
        s.earlyExit = this->EarlyExit;
        s.realizations = this->Realizations;
        s.seed = static_cast<std::uint64_t>(std::max(0, this->Seed));
        s.uniformMinMax = this->UniformWidth != 0;
        s.background = {0.f, 0.f, 0.f};  // premultiplied colour, drawn over the frame buffer
        // A piece of a larger image (MPI ranks): only its samples, the whole grid's sample
        // positions.
        int ext[6];
        image->GetExtent(ext);
        const int* whole = this->WholeExtent;
        if (whole[1] >= whole[0] && !std::equal(ext, ext + 6, whole)) {
            udvr::RenderPiece piece;
            for (int a = 0; a < 3; ++a) {
                const double lo = m.grid.origin[a], hi = m.grid.world(a, m.grid.dims[a] - 1);
                piece.box[2 * a] = ext[2 * a] == whole[2 * a] ? std::min(lo, m.bounds[2 * a]) : lo;
                piece.box[2 * a + 1] =
                    ext[2 * a + 1] == whole[2 * a + 1] ? std::max(hi, m.bounds[2 * a + 1]) : hi;
                piece.offset[a] = ext[2 * a] - whole[2 * a];
                piece.wholeDims[a] = whole[2 * a + 1] - whole[2 * a] + 1;
            }
            s.piece = piece;
        }

        const udvr::ModelKind kind = static_cast<udvr::ModelKind>(this->Model);
        udvr::RenderStats stats;
        udvr::ImageRgba frame;
        const std::string tf2Path =
            this->TransferFunction2DFile ? this->TransferFunction2DFile : "";
        if (!tf2Path.empty()) {
            std::error_code ec;
            const auto t = std::filesystem::last_write_time(tf2Path, ec);
            if (tf2Path != in.tf2Path || t != in.tf2Time) {
                in.tf2Path.clear();
                in.tf2 = tf2Of(tf2Path);
                in.tf2Path = tf2Path;
                in.tf2Time = t;
            }
            frame = udvr::renderVolume(m, kind, in.tf2, s, &stats, &in.cache);
        } else if (in.pvTf2) {
            const vtkMTimeType t = in.pvTf2->GetMTime();
            if (t != in.pvTf2Time || in.pvTf2Built.rgba.empty()) {
                vtkDataArray* a = in.pvTf2->GetPointData()->GetScalars();
                int dims[3];
                in.pvTf2->GetDimensions(dims);
                if (!a || a->GetNumberOfComponents() != 4 || dims[2] != 1)
                    UDVR_FAIL("ParaView's 2D transfer function is not an RGBA raster");
                in.pvTf2Built = tf2OfRaster(in.pvTf2, a, in.pvTf2Range);
                in.pvTf2Time = t;
            }
            frame = udvr::renderVolume(m, kind, in.pvTf2Built, s, &stats, &in.cache);
        } else {
            vtkVolumeProperty* property = vol->GetProperty();
            const udvr::TransferFunction1D tf =
                tfOf(property->GetRGBTransferFunction(0), property->GetScalarOpacity(0));
            frame = udvr::renderVolume(m, kind, tf, s, &stats, &in.cache);
        }
        this->LastFrameMilliseconds = stats.milliseconds;
        if (std::getenv("UDVR_PARAVIEW_VERBOSE"))
            std::fprintf(
                stderr,
                "udvr: pid %ld frame %dx%d %.1f ms; model %.0f MiB (%.0f MiB of it copied); "
                "VmRSS %ld MiB, VmHWM %ld MiB\n",
                static_cast<long>(getpid()), width, height, stats.milliseconds,
                static_cast<double>(modelBytes(m)) / (1 << 20),
                static_cast<double>(in.model.copiedBytes) / (1 << 20), statusMiB("VmRSS"),
                statusMiB("VmHWM"));

        // Rows top to bottom (udvr) → bottom to top (OpenGL); colour over black is premultiplied.
        in.pixels.resize(frame.rgba.size());
        const std::size_t row = static_cast<std::size_t>(width) * 4;
        for (int y = 0; y < height; ++y)
            std::copy_n(frame.rgba.data() + static_cast<std::size_t>(height - 1 - y) * row, row,
                        in.pixels.data() + static_cast<std::size_t>(y) * row);
        auto* window = vtkOpenGLRenderWindow::SafeDownCast(ren->GetRenderWindow());
        if (!window) UDVR_FAIL("Uncertain Volume needs an OpenGL render window");
        vtkOpenGLState* state = window->GetState();
        vtkOpenGLState::ScopedglEnableDisable blendSaver(state, GL_BLEND);
        vtkOpenGLState::ScopedglEnableDisable depthSaver(state, GL_DEPTH_TEST);
        vtkOpenGLState::ScopedglEnableDisable scissorSaver(state, GL_SCISSOR_TEST);
        vtkOpenGLState::ScopedglBlendFuncSeparate blendFuncSaver(state);
        state->vtkglEnable(GL_BLEND);
        state->vtkglBlendFuncSeparate(GL_ONE, GL_ONE_MINUS_SRC_ALPHA, GL_ONE,
                                      GL_ONE_MINUS_SRC_ALPHA);
        window->DrawPixels(x0, y0, x0 + width - 1, y0 + height - 1, 0, 0, width - 1, height - 1,
                           width, height, 4, VTK_FLOAT, in.pixels.data());
        in.lastError.clear();
    } catch (const std::exception& e) {
        // Once per distinct error, not every frame.
        if (in.lastError != e.what()) {
            in.lastError = e.what();
            vtkErrorMacro(<< "udvr: " << e.what());
        }
    }
}

void vtkUdvrVolumeMapper::SetParaViewTransferFunction2D(vtkImageData* raster,
                                                        const double range[4]) {
    Internals& in = *this->Impl;
    const bool sameRange = raster && std::equal(range, range + 4, in.pvTf2Range);
    if (in.pvTf2.GetPointer() == raster && (sameRange || !raster)) return;
    in.pvTf2 = raster;
    if (raster) std::copy(range, range + 4, in.pvTf2Range);
    in.pvTf2Built = udvr::TransferFunction2D{};
    this->Modified();
}

void vtkUdvrVolumeMapper::PrintSelf(ostream& os, vtkIndent indent) {
    this->Superclass::PrintSelf(os, indent);
    os << indent << "Model: " << this->Model << "\n";
    os << indent << "Step: " << this->Step << "\n";
    os << indent << "UnitDistance: " << this->UnitDistance << "\n";
}
