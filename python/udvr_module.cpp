// `udvr._udvr`, the compiled half of the Python package `udvr` (python/udvr/): a thin pybind11
// layer over the library (no algorithm of its own).
// Arrays cross as NumPy arrays in C order (z, y, x), so x is fastest as in SPEC §1.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <future>
#include <optional>
#include <string_view>
#include <tuple>
#include <utility>
#include <variant>

#include "udvr/classify/model_families.h"
#include "udvr/classify/model_kind.h"
#include "udvr/classify/probe.h"
#include "udvr/classify/tf_presets.h"
#include "udvr/data/noise.h"
#include "udvr/data/synthetic.h"
#include "udvr/eval/experiments.h"
#include "udvr/eval/image_metrics.h"
#include "udvr/io/ensemble_io.h"
#include "udvr/io/field_io.h"
#include "udvr/io/image.h"
#include "udvr/io/model_io.h"
#include "udvr/io/transfer_function_2d_io.h"
#include "udvr/io/transfer_function_io.h"
#include "udvr/render/camera.h"
#include "udvr/render/framing.h"
#include "udvr/render/render.h"
#include "udvr/render/render_options.h"
#include "udvr/stats/build_model.h"
#include "udvr/stats/model_volume.h"
#include "udvr/util/build_info.h"
#include "udvr/util/check.h"
#include "udvr/util/parallel.h"
#include "udvr/util/progress.h"

namespace py = pybind11;
using namespace udvr;

namespace {

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

// A per-voxel array (n components) as a NumPy array of shape (Z, Y, X[, n]).
FloatArray voxelArray(const Grid3& g, const std::vector<float>& values, int components) {
    std::vector<py::ssize_t> shape{g.dims[2], g.dims[1], g.dims[0]};
    if (components > 1) shape.push_back(components);
    FloatArray a(shape);
    if (values.size() != static_cast<std::size_t>(a.size()))
        throw UdvrError("array size does not match the grid");
    std::memcpy(a.mutable_data(), values.data(), values.size() * sizeof(float));
    return a;
}

std::vector<float> toVector(const FloatArray& a) {
    return std::vector<float>(a.data(), a.data() + a.size());
}

// An array's shape as "5, 0, 8, 8".
std::string shapeText(const FloatArray& a) {
    std::string shape;
    for (py::ssize_t d = 0; d < a.ndim(); ++d)
        shape += (d ? ", " : "") + std::to_string(a.shape(d));
    return shape;
}

Grid3 gridFromShape(const FloatArray& a, int leadingDims) {
    if (a.ndim() != 3 + leadingDims)
        throw UdvrError("expected an array of " + std::to_string(3 + leadingDims) + " dimensions");
    Grid3 g;
    g.dims = {static_cast<int>(a.shape(2 + leadingDims)),
              static_cast<int>(a.shape(1 + leadingDims)), static_cast<int>(a.shape(leadingDims))};
    return g;
}

// A field or an ensemble (T) from an array of (leadingDims axes, Z, Y, X), placed in the world:
// every axis at least one point, a finite origin, a positive finite spacing. `what` names it in
// errors ("Field").
template <class T>
T gridded(const FloatArray& values, int leadingDims, const std::array<double, 3>& origin,
          const std::array<double, 3>& spacing, std::string name, const char* what) {
    T t;
    t.grid = gridFromShape(values, leadingDims);
    for (int a = 0; a < 3; ++a) {
        if (t.grid.dims[a] < 1) {
            UDVR_FAIL(what << ": every grid axis needs at least 1 point, got shape ("
                           << shapeText(values) << ")");
        }
        if (!std::isfinite(origin[a]) || !(spacing[a] > 0.0) || !std::isfinite(spacing[a]))
            UDVR_FAIL(what << ": spacing must be positive and origin finite, got origin ("
                           << origin[0] << ", " << origin[1] << ", " << origin[2] << ") spacing ("
                           << spacing[0] << ", " << spacing[1] << ", " << spacing[2] << ")");
    }
    t.grid.origin = origin;
    t.grid.spacing = spacing;
    t.values = toVector(values);
    t.name = std::move(name);
    return t;
}

// A per-voxel array with `components` values per voxel on grid g (components 0: no trailing axis).
std::vector<float> voxelValues(const std::optional<FloatArray>& a, const Grid3& g, int components,
                               const char* name) {
    if (!a) return {};
    const int nd = components > 0 ? 4 : 3;
    bool ok = a->ndim() == nd && a->shape(0) == g.dims[2] && a->shape(1) == g.dims[1] &&
              a->shape(2) == g.dims[0];
    if (ok && components > 0) ok = a->shape(3) == components;
    if (!ok)
        throw UdvrError(std::string("Model: array '") + name + "' must have shape (" +
                        std::to_string(g.dims[2]) + ", " + std::to_string(g.dims[1]) + ", " +
                        std::to_string(g.dims[0]) +
                        (components > 0 ? ", " + std::to_string(components) : std::string()) + ")");
    std::vector<float> v = toVector(*a);
    for (float x : v)
        if (!std::isfinite(x))
            throw UdvrError(std::string("Model: array '") + name + "' holds NaN or Inf");
    return v;
}

// An array of real numbers (any real dtype, a list) as C-ordered float32; complex, object,
// string and date arrays are a TypeError (a cast would drop the imaginary part silently).
FloatArray realArray(const py::handle& h, const char* name) {
    py::array a = py::array::ensure(h);
    const char kind = a ? a.dtype().kind() : 'O';
    if (kind != 'b' && kind != 'i' && kind != 'u' && kind != 'f')
        throw py::type_error(std::string(name) +
                             " must hold real numbers (bool, integer or float), got " +
                             (a ? "dtype " + std::string(py::str(a.dtype()))
                                : std::string(py::str(py::type::of(h).attr("__name__")))));
    return FloatArray::ensure(a);
}

std::optional<FloatArray> optionalRealArray(const py::object& o, const char* name) {
    if (o.is_none()) return std::nullopt;
    return realArray(o, name);
}

ModelVolume modelFromArrays(
    const py::object& meanIn, const py::object& stddevIn, const py::object& minIn,
    const py::object& maxIn, const py::object& quantilesIn, const py::object& iqrIn,
    const py::object& gmmIn, std::array<double, 3> origin, std::array<double, 3> spacing,
    const std::optional<std::array<double, 6>>& bounds,
    const std::optional<double>& fullResMinSpacing, int downsample, int samplesPerVoxel,
    const std::string& density, const std::string& source, double bandwidth,
    const std::string& bandwidthRule, double tailEps, const std::vector<double>& quantileLevels) {
    const FloatArray mean = realArray(meanIn, "Model: mean");
    const auto stddev = optionalRealArray(stddevIn, "Model: stddev");
    const auto min = optionalRealArray(minIn, "Model: min");
    const auto max = optionalRealArray(maxIn, "Model: max");
    const auto quantiles = optionalRealArray(quantilesIn, "Model: quantiles");
    const auto iqr = optionalRealArray(iqrIn, "Model: iqr");
    const auto gmm = optionalRealArray(gmmIn, "Model: gmm");
    ModelVolume mv;
    mv.grid = gridFromShape(mean, 0);
    for (int a = 0; a < 3; ++a) {
        if (mv.grid.dims[a] < 1) throw UdvrError("Model: every grid axis needs at least 1 point");
        if (!(spacing[a] > 0.0) || !std::isfinite(spacing[a]) || !std::isfinite(origin[a]))
            throw UdvrError("Model: spacing must be positive and origin finite");
    }
    mv.grid.origin = origin;
    mv.grid.spacing = spacing;
    mv.mean = voxelValues(mean, mv.grid, 0, "mean");
    mv.stddev = stddev ? voxelValues(stddev, mv.grid, 0, "stddev")
                       : std::vector<float>(mv.mean.size(), 0.f);
    mv.min = min ? voxelValues(min, mv.grid, 0, "min") : mv.mean;
    mv.max = max ? voxelValues(max, mv.grid, 0, "max") : mv.mean;
    if (quantiles) {
        if (quantiles->ndim() != 4 || quantiles->shape(3) < 2)
            throw UdvrError("Model: 'quantiles' must have shape (Z, Y, X, q+1) with q >= 1");
        mv.quantileCount = static_cast<int>(quantiles->shape(3)) - 1;
        mv.quantiles = voxelValues(quantiles, mv.grid, mv.quantileCount + 1, "quantiles");
        mv.quantileLevels =
            normalizedQuantileLevels(quantileLevels, mv.quantileCount, "Model: quantile_levels");
    } else if (!quantileLevels.empty()) {
        throw UdvrError("Model: quantile_levels needs a 'quantiles' array");
    }
    mv.iqr = voxelValues(iqr, mv.grid, 2, "iqr");
    if (gmm) {
        if (gmm->ndim() != 4 || gmm->shape(3) < 3 || gmm->shape(3) % 3 != 0)
            throw UdvrError("Model: 'gmm' must have shape (Z, Y, X, 3K) with K >= 1");
        mv.gmmComponents = static_cast<int>(gmm->shape(3)) / 3;
        mv.gmm = voxelValues(gmm, mv.grid, 3 * mv.gmmComponents, "gmm");
    }
    mv.bounds = bounds ? *bounds : mv.grid.bounds();
    mv.fullResMinSpacing = fullResMinSpacing ? *fullResMinSpacing : mv.grid.minSpacing();
    if (!(mv.fullResMinSpacing > 0.0))
        throw UdvrError("Model: full_res_min_spacing must be positive");
    mv.downsample = downsample;
    mv.samplesPerVoxel = samplesPerVoxel;
    mv.density = density;
    mv.source = source;
    mv.bandwidth = bandwidth;
    mv.bandwidthRule = bandwidthRule;
    mv.tailEps = tailEps;
    checkModelArrays(mv, "Model");
    return mv;
}

// The docstring of each per-voxel array of SPEC §7 (kModelFileArrays) as the Python Model
// shows it.
std::string modelArrayDoc(std::string_view name) {
    constexpr std::pair<std::string_view, const char*> kDocs[] = {
        {"mean", "μ per voxel, (Z, Y, X)"},
        {"stddev", "σ per voxel (ddof = 1), (Z, Y, X)"},
        {"min", "sample minimum per voxel, (Z, Y, X)"},
        {"max", "sample maximum per voxel, (Z, Y, X)"},
        {"quantiles", "boundaries b_0..b_q per voxel, (Z, Y, X, q+1); None when not built"},
        {"iqr", "b(0.25), b(0.75) per voxel, (Z, Y, X, 2); None when not built"},
        {"gmm", "π_1..π_K, μ_1..μ_K, σ_1..σ_K per voxel, (Z, Y, X, 3K); None when not built"},
    };
    for (const auto& [n, doc] : kDocs)
        if (n == name) return doc;
    UDVR_CHECK_MSG(false, "every model file array has a docstring");
    return {};
}

// A read-only NumPy view of one of the model's arrays (no copy): `owner`, the Python Model,
// stays alive as long as the view does. None where the model has no such array.
py::object modelView(py::handle owner, const Grid3& g, const std::vector<float>& values,
                     int components) {
    if (values.empty()) return py::none();
    std::vector<py::ssize_t> shape{g.dims[2], g.dims[1], g.dims[0]};
    if (components > 1) shape.push_back(components);
    py::ssize_t n = 1;
    for (py::ssize_t d : shape) n *= d;
    if (values.size() != static_cast<std::size_t>(n))
        throw UdvrError("array size does not match the grid");
    py::array_t<float> a(shape, values.data(), owner);
    py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
    return a;
}

// An image as an (H, W, 4) float32 array that owns the image's pixels (moved, not copied).
py::array imageArray(ImageRgba&& image) {
    auto* pixels = new std::vector<float>(std::move(image.rgba));
    py::capsule owner(pixels, [](void* p) { delete static_cast<std::vector<float>*>(p); });
    return py::array_t<float>({static_cast<py::ssize_t>(image.height),
                               static_cast<py::ssize_t>(image.width), py::ssize_t{4}},
                              pixels->data(), owner);
}

// An (H, W, 4) or (H, W, 3) array (RGB: alpha 1) as an image.
ImageRgba imageFromArray(const FloatArray& a, const char* name) {
    if (a.ndim() != 3 || (a.shape(2) != 3 && a.shape(2) != 4) || a.shape(0) < 1 || a.shape(1) < 1)
        throw UdvrError(std::string(name) + " must be an (H, W, 4) or (H, W, 3) image array");
    ImageRgba img;
    img.height = static_cast<int>(a.shape(0));
    img.width = static_cast<int>(a.shape(1));
    const auto channels = static_cast<std::size_t>(a.shape(2));
    img.rgba.resize(static_cast<std::size_t>(img.width) * img.height * 4, 1.f);
    const float* src = a.data();
    for (std::size_t p = 0; p < img.rgba.size() / 4; ++p)
        for (std::size_t c = 0; c < channels; ++c) img.rgba[4 * p + c] = src[channels * p + c];
    return img;
}

// Run `work` on a worker thread with the GIL released while this thread, about 10 times a
// second, runs Python's signal handlers (PyErr_CheckSignals: Ctrl-C raises KeyboardInterrupt)
// and then `poll()` (which may raise). When either raises, `stop()` asks the work to stop, this
// thread waits for it (its arrays are borrowed from Python) and the Python exception propagates;
// the work's own exception, if it ended with one, is dropped.
template <class Work, class Stop, class Poll>
auto interruptible(Work work, Stop stop, Poll poll) {
    auto future = std::async(std::launch::async, std::move(work));
    const auto stopAndWait = [&] {
        stop();
        py::gil_scoped_release release;
        future.wait();
    };
    for (;;) {
        {
            py::gil_scoped_release release;
            if (future.wait_for(std::chrono::milliseconds(100)) == std::future_status::ready) break;
        }
        if (PyErr_CheckSignals() != 0) {
            stopAndWait();
            throw py::error_already_set();
        }
        try {
            poll();
        } catch (...) {
            stopAndWait();
            throw;
        }
    }
    py::gil_scoped_release release;
    return future.get();  // the work's exception, if any
}

// Run `work` (which advances `bar`) interruptibly. With a `progress(done, total)` callable, it is
// called about 10 times a second and once at the end when the work succeeded (on the caller's
// thread, as notebook widgets want); an exception it raises cancels the work (the bar's next
// advance throws) and propagates, as does Ctrl-C.
template <class Work>
auto withProgress(Work work, ProgressBar& bar, const py::object& progress) {
    const auto report = [&](std::size_t done) {
        if (!progress.is_none()) progress(done, bar.total());
    };
    auto result = interruptible(
        std::move(work), [&] { bar.cancel(); }, [&] { report(bar.done()); });
    report(bar.total());
    return result;
}

struct BuildResult {
    ModelVolume model;
    BuildReport report;
};

// `udvr build` from an array: (members, Z, Y, X) ensemble, or a (Z, Y, X) field in K³ bricks
// (downsample = K ≥ 2). The options are fitted to the samples per voxel as the CLI does;
// returns (model, warnings, info, dropped planes in x, y, z).
py::tuple buildFromArray(const FloatArray& values, std::array<double, 3> origin,
                         std::array<double, 3> spacing, int downsample, BuildOptions opt,
                         bool gmmGiven, bool quantilesGiven, const py::object& progress,
                         double valueStep, const std::string& valueType) {
    const bool bricks = downsample != 0;
    const std::string shape = shapeText(values);
    for (py::ssize_t d = 0; d < values.ndim(); ++d)
        if (values.shape(d) < 1)
            UDVR_FAIL("build: the (" << shape << ") array is empty along axis " << d
                                     << "; expected at least one member and one grid point per "
                                        "axis");
    const Grid3 grid = [&] {
        Grid3 g = gridFromShape(values, bricks ? 0 : 1);
        g.origin = origin;
        g.spacing = spacing;
        return g;
    }();
    for (int a = 0; a < 3; ++a)
        if (!(spacing[a] > 0.0) || !std::isfinite(spacing[a]) || !std::isfinite(origin[a]))
            throw UdvrError("spacing must be positive and origin finite");
    const Grid3 model = bricks ? downsampledGrid(grid, downsample) : grid;
    const long long n = bricks ? 1LL * downsample * downsample * downsample : values.shape(0);
    checkDensityForInput(opt.density, valueStep, valueType);
    const BuildFitNotes notes = fitBuildOptionsToSamples(opt, n, gmmGiven, quantilesGiven);
    ProgressBar bar("build", model.pointCount(), 0.0, /*draw=*/false);
    opt.progress = &bar;
    const float* data = values.data();
    const auto count = static_cast<std::size_t>(values.size());
    BuildResult r = withProgress(
        [&, data, count] {
            BuildResult out;
            if (bricks) {
                ScalarField f{grid, std::vector<float>(data, data + count), "value"};
                f.valueStep = valueStep;
                f.valueType = valueType;
                out.model = buildModelDownsampled(f, downsample, opt, &out.report);
            } else {
                Ensemble e{grid, static_cast<int>(n), std::vector<float>(data, data + count),
                           "value"};
                e.valueStep = valueStep;
                e.valueType = valueType;
                out.model = buildModel(e, opt, &out.report);
            }
            return out;
        },
        bar, progress);
    return py::make_tuple(std::move(r.model), notes.warnings, notes.info, r.report.droppedPlanes);
}

// What probe returns to Python: (the SPEC §8 JSON text, exactly as `probe --json` prints it,
// and the distribution's CDF for plots).
py::tuple probeOutput(const ProbeResult& r) {
    const ProbeDistribution& d = r.distribution;
    py::dict dist;
    dist["lo"] = d.lo;
    dist["hi"] = d.hi;
    dist["continuous_mass"] = d.continuousMass;
    dist["atoms"] = py::array_t<double>(static_cast<py::ssize_t>(d.atoms.size()), d.atoms.data());
    dist["atom_mass"] =
        py::array_t<double>(static_cast<py::ssize_t>(d.atomMass.size()), d.atomMass.data());
    dist["cdf_x"] = py::array_t<double>(static_cast<py::ssize_t>(d.cdfX.size()), d.cdfX.data());
    dist["cdf_y"] = py::array_t<double>(static_cast<py::ssize_t>(d.cdfY.size()), d.cdfY.data());
    return py::make_tuple(r.json.dump(2), dist);
}

// The options given as [(keyword, text as the CLI takes it)], each looked up in `tables` by its
// name and set by the same code as the CLI's flags; a keyword in none of them is a TypeError.
RenderOptions optionsGiven(const std::vector<std::pair<std::string, std::string>>& given,
                           std::initializer_list<std::span<const OptionSpec>> tables) {
    RenderOptions options;
    for (const auto& [key, value] : given) {
        const OptionSpec* spec = findOptionSpec(key);
        bool inTables = false;
        for (auto table : tables)
            inTables =
                inTables || (spec && spec >= table.data() && spec < table.data() + table.size());
        if (!inTables) throw py::type_error("unknown option '" + key + "'");
        setOption(options, *spec, value, key);
    }
    return options;
}

// (keyword, type, default, range, help) of each option of `tables`: keyword is the name with '_'
// for '-', type text/real/whole/flag, range as setOption states it (None for text and flags).
py::list optionRows(std::initializer_list<std::span<const OptionSpec>> tables) {
    py::list out;
    for (auto table : tables)
        for (const OptionSpec& spec : table) {
            std::string name = spec.name;
            for (char& c : name)
                if (c == '-') c = '_';
            const char* type = std::visit(
                [](auto v) -> const char* {
                    using T = decltype(v);
                    if constexpr (std::is_same_v<T, const char*>) return "text";
                    if constexpr (std::is_same_v<T, double>) return "real";
                    if constexpr (std::is_same_v<T, bool>) return "flag";
                    return "whole";
                },
                spec.defaultValue);
            const py::object value =
                std::visit([](auto v) -> py::object { return py::cast(v); }, spec.defaultValue);
            const std::string range = optionRangeText(spec);
            out.append(py::make_tuple(name, type, value,
                                      range.empty() ? py::object(py::none()) : py::str(range),
                                      optionHelp(spec)));
        }
    return out;
}

// probe at an index-space point with a 1D or 2D TF; `given`: the classification options.
template <class Tf>
py::tuple probeAt(const ModelVolume& model, const std::string& kind, const Tf& tf,
                  std::array<double, 3> point,
                  const std::vector<std::pair<std::string, std::string>>& given) {
    const ClassifyOptions o =
        classifyOptionsFrom(optionsGiven(given, {classificationOptionSpecs()}));
    return probeOutput(probeModel(model, parseModelKind(kind), tf, point, o));
}

// A render that Ctrl-C stops (RenderSettings::cancel) with KeyboardInterrupt.
template <class Render>
ImageRgba renderInterruptibly(const RenderSettings& s, Render render) {
    std::atomic<bool> cancel{false};
    RenderSettings settings = s;
    settings.cancel = &cancel;
    return interruptible([&] { return render(settings); }, [&] { cancel.store(true); }, [] {});
}

template <class Tf>
py::array renderArray(const ModelVolume& model, const std::string& kind, const Tf& tf,
                      const RenderSettings& s) {
    const ModelKind k = parseModelKind(kind);
    return imageArray(renderInterruptibly(
        s, [&](const RenderSettings& settings) { return renderVolume(model, k, tf, settings); }));
}

}  // namespace

PYBIND11_MODULE(_udvr, m) {
    m.doc() =
        "udvr's compiled core (the package `udvr` wraps it): direct volume rendering of "
        "uncertain data (Athawale et al., TVCG 2021)";
    m.attr("__version__") = std::string(udvr::build::kVersion);  // as `udvr --version`
    // e.g. "target native: AVX-512, 16-float lanes in 1 register of 512 bits" (as `udvr --version`)
    m.attr("__build__") = std::string(udvr::build::buildDescription());
    // C++ user errors arrive with the CLI's message: files as OSError, the rest as ValueError
    // (pybind11 tries the translator registered last first).
    py::register_exception<UdvrError>(m, "UdvrError", PyExc_ValueError);
    py::register_exception<FileError>(m, "FileError", PyExc_OSError);

    py::class_<Grid3>(m, "Grid")
        .def(py::init<>())
        .def_readwrite("dims", &Grid3::dims, "points per axis (x, y, z)")
        .def_readwrite("origin", &Grid3::origin, "world position of point (0,0,0)")
        .def_readwrite("spacing", &Grid3::spacing, "world distance between points")
        .def("bounds", &Grid3::bounds)
        .def("__repr__", [](const Grid3& g) {
            return "Grid(dims=" + std::to_string(g.dims[0]) + "x" + std::to_string(g.dims[1]) +
                   "x" + std::to_string(g.dims[2]) + ")";
        });

    py::class_<ScalarField>(m, "Field")
        .def(py::init([](const py::object& valuesIn, std::array<double, 3> origin,
                         std::array<double, 3> spacing, std::string name) {
                 ScalarField f = gridded<ScalarField>(realArray(valuesIn, "Field: values"), 0,
                                                      origin, spacing, std::move(name), "Field");
                 // A field is a value per voxel: NaN/Inf would classify as NaN pixels.
                 const auto nx = static_cast<std::size_t>(f.grid.dims[0]);
                 const auto ny = static_cast<std::size_t>(f.grid.dims[1]);
                 for (std::size_t v = 0; v < f.values.size(); ++v)
                     if (!std::isfinite(f.values[v]))
                         UDVR_FAIL("Field: values hold "
                                   << (std::isnan(f.values[v]) ? "NaN" : "Inf") << " at voxel ("
                                   << v % nx << ", " << v / nx % ny << ", " << v / (nx * ny)
                                   << ") (array index [" << v / (nx * ny) << ", " << v / nx % ny
                                   << ", " << v % nx << "])");
                 return f;
             }),
             py::arg("values"), py::arg("origin") = std::array<double, 3>{0, 0, 0},
             py::arg("spacing") = std::array<double, 3>{1, 1, 1}, py::arg("name") = "value",
             "a field from a (Z, Y, X) array")
        .def_readwrite("grid", &ScalarField::grid)
        .def_readwrite("name", &ScalarField::name)
        .def_property_readonly(
            "values", [](const ScalarField& f) { return voxelArray(f.grid, f.values, 1); },
            "the values as a (Z, Y, X) float32 array (a copy)")
        .def_readonly("value_step", &ScalarField::valueStep,
                      "the file type's quantisation step: 1 for integers, 0 for floats")
        .def_readonly("value_type", &ScalarField::valueType, "the file's value type (uint8 …)");

    py::class_<Ensemble>(m, "Ensemble")
        .def(py::init([](const py::object& valuesIn, std::array<double, 3> origin,
                         std::array<double, 3> spacing, std::string name) {
                 const FloatArray values = realArray(valuesIn, "Ensemble: values");
                 Ensemble e =
                     gridded<Ensemble>(values, 1, origin, spacing, std::move(name), "Ensemble");
                 e.members = static_cast<int>(values.shape(0));
                 return e;
             }),
             py::arg("values"), py::arg("origin") = std::array<double, 3>{0, 0, 0},
             py::arg("spacing") = std::array<double, 3>{1, 1, 1}, py::arg("name") = "value",
             "an ensemble from a (members, Z, Y, X) array")
        .def_readwrite("grid", &Ensemble::grid)
        .def_readonly("members", &Ensemble::members)
        .def_readonly("name", &Ensemble::name)
        .def_property_readonly(
            "values",
            [](const Ensemble& e) {
                FloatArray a({static_cast<py::ssize_t>(e.members),
                              static_cast<py::ssize_t>(e.grid.dims[2]),
                              static_cast<py::ssize_t>(e.grid.dims[1]),
                              static_cast<py::ssize_t>(e.grid.dims[0])});
                std::memcpy(a.mutable_data(), e.values.data(), e.values.size() * sizeof(float));
                return a;
            },
            "the members as a (members, Z, Y, X) float32 array (a copy)")
        .def_readonly("value_step", &Ensemble::valueStep,
                      "the file type's quantisation step: 1 for integers, 0 for floats")
        .def_readonly("value_type", &Ensemble::valueType, "the files' value type (uint8 …)");

    py::class_<ModelVolume> modelClass(m, "Model");
    modelClass
        .def(py::init(&modelFromArrays), py::arg("mean"), py::kw_only(),
             py::arg("stddev") = py::none(), py::arg("min") = py::none(),
             py::arg("max") = py::none(), py::arg("quantiles") = py::none(),
             py::arg("iqr") = py::none(), py::arg("gmm") = py::none(),
             py::arg("origin") = std::array<double, 3>{0, 0, 0},
             py::arg("spacing") = std::array<double, 3>{1, 1, 1}, py::arg("bounds") = py::none(),
             py::arg("full_res_min_spacing") = py::none(), py::arg("downsample") = 0,
             py::arg("samples_per_voxel") = 0, py::arg("density") = "empirical",
             py::arg("source") = "python", py::arg("bandwidth") = 0.0,
             py::arg("bandwidth_rule") = "", py::arg("tail_eps") = 0.0,
             py::arg("quantile_levels") = std::vector<double>{},
             "a model from NumPy arrays of shape (Z, Y, X[, components]): mean (required), "
             "stddev, min, max (default: mean), quantiles (Z,Y,X,q+1), iqr (Z,Y,X,2), gmm "
             "(Z,Y,X,3K: pi_1..pi_K, mu_1..mu_K, sigma_1..sigma_K); bounds (xmin,xmax,ymin,ymax,"
             "zmin,zmax) and full_res_min_spacing default to the model grid's")
        .def_property_readonly(
            "grid", [](const ModelVolume& mv) { return mv.grid; }, "the model's grid (a copy)")
        .def_readonly("quantile_count", &ModelVolume::quantileCount)
        .def_property_readonly(
            "quantile_levels",
            [](const ModelVolume& mv) {
                std::vector<double> t;
                for (int j = 0; mv.hasQuantiles() && j <= mv.quantileCount; ++j)
                    t.push_back(mv.quantileLevel(j));
                return t;
            },
            "the q + 1 levels t_0 = 0 … t_q = 1 of the quantile boundaries")
        .def_readonly("gmm_components", &ModelVolume::gmmComponents)
        .def_readonly("density", &ModelVolume::density)
        .def_readonly("samples_per_voxel", &ModelVolume::samplesPerVoxel)
        .def_readonly("member_count", &ModelVolume::memberCount,
                      "members held for model 'members' (0: none; udvr.render(ensemble, "
                      "'members') holds them)")
        .def_readonly("downsample", &ModelVolume::downsample)
        .def_readonly("bounds", &ModelVolume::bounds)
        .def_readonly("full_res_min_spacing", &ModelVolume::fullResMinSpacing)
        .def_readonly("bandwidth", &ModelVolume::bandwidth, "kde: median h over voxels, else 0")
        .def_readonly("bandwidth_rule", &ModelVolume::bandwidthRule)
        .def_readonly("tail_eps", &ModelVolume::tailEps)
        .def_readonly("source", &ModelVolume::source)
        .def(
            "array",
            [](const ModelVolume& mv, const std::string& name) {
                for (const ModelFileArray& a : kModelFileArrays)
                    if (name == a.name)
                        return voxelArray(mv.grid, mv.*a.values, a.floatsPerVoxel(mv));
                throw UdvrError("unknown model array '" + name +
                                "'; expected mean, stddev, min, max, quantiles, iqr or gmm");
            },
            py::arg("name"), "a per-voxel array as (Z, Y, X[, components]) (a copy)");
    for (const ModelFileArray& a : kModelFileArrays)
        modelClass.def_property_readonly(
            a.name,
            [&a](py::object self) {
                const auto& mv = self.cast<const ModelVolume&>();
                return modelView(self, mv.grid, mv.*a.values, a.floatsPerVoxel(mv));
            },
            (modelArrayDoc(a.name) + ": a read-only view of the model's memory (no copy)").c_str());

    py::class_<TransferFunction1D>(m, "TransferFunction")
        .def(py::init([](const std::vector<std::array<double, 4>>& colors,
                         const std::vector<std::array<double, 2>>& opacities) {
                 TransferFunction1D tf;
                 for (const auto& c : colors) {
                     tf.colorX.push_back(c[0]);
                     tf.color.push_back({c[1], c[2], c[3]});
                 }
                 for (const auto& o : opacities) {
                     tf.opacityX.push_back(o[0]);
                     tf.opacity.push_back(o[1]);
                 }
                 tf.validate();
                 return tf;
             }),
             py::arg("colors"), py::arg("opacities"),
             "a 1D TF from control points: colors [(x, r, g, b), ...], opacities [(x, alpha), "
             "...], x ascending (a repeated x makes a step), values in [0, 1] (SPEC §4)")
        .def_static("from_json", &parseTransferFunction, py::arg("text"),
                    py::arg("what") = "transfer function JSON",
                    "a TF from ParaView JSON text (RGBPoints, Points)")
        .def_static("read", &readTransferFunction, py::arg("path"),
                    "a TF from a ParaView JSON file")
        .def_static("preset", &transferFunctionPreset, py::arg("name"), py::arg("range"),
                    py::arg("ramp_start"),
                    "a named preset over [range[0], range[1]]: opacity 0 below ramp_start, "
                    "then rising to 0.5")
        .def_static(
            "preset_over",
            [](const std::string& name, const py::object& valuesIn,
               std::optional<std::array<double, 2>> range) {
                const FloatArray values = realArray(valuesIn, "values");
                if (range && !((*range)[0] < (*range)[1])) throw UdvrError("range expects lo < hi");
                return transferFunctionPresetOver(
                           name,
                           std::span<const float>(values.data(),
                                                  static_cast<std::size_t>(values.size())),
                           range)
                    .tf;
            },
            py::arg("name"), py::arg("values"), py::arg("range") = py::none(),
            "the preset over bare values (no grid): colours over their 0.5-99.5th percentiles "
            "(or `range`), opacity rising from their median; preset_for(name, model) is the "
            "default TF of `udvr render` (boundary opacity, docs/rendering.md)")
        .def_static(
            "preset_for",
            [](const std::string& name, const ModelVolume& model,
               std::optional<std::array<double, 2>> range) {
                if (range && !((*range)[0] < (*range)[1])) throw UdvrError("range expects lo < hi");
                return transferFunctionPresetOver(name, defaultTfBasisOf(model), range).tf;
            },
            py::arg("name"), py::arg("model"), py::arg("range") = py::none(),
            "the preset `udvr render MODEL` uses without --tf: colours over the 0.5-99.5th "
            "percentiles of the model's source (or `range`), the default opacity of "
            "docs/rendering.md")
        .def_static("preset_names", &transferFunctionPresetNames)
        .def("to_json", &transferFunctionToJson, py::arg("name") = "udvr",
             "ParaView JSON text (as `--save-tf` writes)")
        .def_property_readonly(
            "colors",
            [](const TransferFunction1D& tf) {
                std::vector<std::array<double, 4>> v;
                for (std::size_t i = 0; i < tf.colorX.size(); ++i)
                    v.push_back({tf.colorX[i], tf.color[i][0], tf.color[i][1], tf.color[i][2]});
                return v;
            },
            "colour control points [(x, r, g, b), ...]")
        .def_property_readonly(
            "opacities",
            [](const TransferFunction1D& tf) {
                std::vector<std::array<double, 2>> v;
                for (std::size_t i = 0; i < tf.opacityX.size(); ++i)
                    v.push_back({tf.opacityX[i], tf.opacity[i]});
                return v;
            },
            "opacity control points [(x, alpha), ...]")
        .def(
            "__call__",
            [](const TransferFunction1D& tf, const py::array_t<double, py::array::forcecast>& x) {
                // (..., 4): straight colour and opacity (r, g, b, α) at each x.
                std::vector<py::ssize_t> shape(x.shape(), x.shape() + x.ndim());
                shape.push_back(4);
                py::array_t<double> out(shape);
                const double* in = x.data();
                double* o = out.mutable_data();
                for (py::ssize_t i = 0; i < x.size(); ++i) {
                    const auto c = tf.colorAt(in[i]);
                    o[4 * i] = c[0];
                    o[4 * i + 1] = c[1];
                    o[4 * i + 2] = c[2];
                    o[4 * i + 3] = tf.opacityAt(in[i]);
                }
                return out;
            },
            py::arg("x"), "(r, g, b, alpha) at each x: an array of shape x.shape + (4,)")
        .def("classify", &TransferFunction1D::classify)
        .def("domain", &TransferFunction1D::domain);

    py::class_<TransferFunction2D>(m, "TransferFunction2D")
        .def_static(
            "read",
            [](const std::filesystem::path& path, std::optional<std::array<double, 4>> domain,
               std::optional<std::array<int, 2>> resolution, bool force) {
                Tf2ReadOptions o;
                o.domain = domain;
                o.resolution = resolution;
                o.force = force;
                return readTransferFunction2D(path, o);
            },
            py::arg("path"), py::arg("domain") = py::none(), py::arg("resolution") = py::none(),
            py::kw_only(), py::arg("force") = false,
            "a 2D TF (SPEC §9) from a raster .vti, an .npy with domain=(x0, x1, y0, y1), or a "
            "widget .json (rasterised at resolution=(W, H); over 1e8 widget evaluations, points "
            "x widgets, need force=True)")
        .def_static(
            "from_widgets",
            [](const std::string& json, std::optional<std::array<int, 2>> resolution, bool force) {
                Tf2ReadOptions o;
                o.resolution = resolution;
                o.force = force;
                return transferFunction2DFromWidgets(json, "widget JSON", o);
            },
            py::arg("json"), py::arg("resolution") = py::none(), py::kw_only(),
            py::arg("force") = false, "a 2D TF from widget JSON text (docs/formats.md)")
        .def_readonly("x0", &TransferFunction2D::x0)
        .def_readonly("x1", &TransferFunction2D::x1)
        .def_readonly("y0", &TransferFunction2D::y0)
        .def_readonly("y1", &TransferFunction2D::y1)
        .def_property_readonly(
            "raster",
            [](const TransferFunction2D& tf) {
                FloatArray a({static_cast<py::ssize_t>(tf.height),
                              static_cast<py::ssize_t>(tf.width), py::ssize_t{4}});
                std::memcpy(a.mutable_data(), tf.rgba.data(), tf.rgba.size() * sizeof(float));
                return a;
            },
            "(H, W, 4) r, g, b, alpha; row 0 at y0, column 0 at x0 (a copy)")
        .def("classify", &TransferFunction2D::classify, py::arg("x"), py::arg("y"));
    py::class_<Rgba>(m, "Rgba")
        .def_readonly("r", &Rgba::r)
        .def_readonly("g", &Rgba::g)
        .def_readonly("b", &Rgba::b)
        .def_readonly("a", &Rgba::a)
        .def("__iter__",
             [](const Rgba& c) { return py::iter(py::make_tuple(c.r, c.g, c.b, c.a)); });

    m.def(
        "set_threads",
        [](long long threads) {
            if (threads < 0) UDVR_FAIL("threads must be >= 0 (0 = all cores), got " << threads);
            return setThreadCount(static_cast<int>(std::min<long long>(threads, maxThreadCount())));
        },
        py::arg("threads"),
        "worker threads (0 = all cores; more than 4x the hardware threads are clamped to that); "
        "returns the count in use");
    m.def(
        "generate",
        [](const std::string& name, std::array<int, 3> dims) {
            return makeSyntheticField(name, dims[0], dims[1], dims[2]);
        },
        py::arg("name"), py::arg("dims") = std::array<int, 3>{64, 64, 64},
        "a synthetic field: tangle, teardrop, spheres, marschner-lobb");
    m.def(
        "perturb",
        [](const ScalarField& field, int members, const std::string& noise, std::uint64_t seed,
           double sigma, double width, double outlierFraction, double outlierOffset,
           double outlierSigma) {
            NoiseParams p;
            p.kind = parseNoiseKind(noise);
            p.seed = seed;
            p.sigma = sigma;
            p.width = width;
            p.outlierFraction = outlierFraction;
            p.outlierOffset = outlierOffset;
            p.outlierSigma = outlierSigma;
            py::gil_scoped_release release;
            return perturbField(field, members, p);
        },
        py::arg("field"), py::arg("members") = 50, py::arg("noise") = "bimodal",
        py::arg("seed") = 1, py::arg("sigma") = 0.02, py::arg("width") = 0.05,
        py::arg("outlier_fraction") = 0.2, py::arg("outlier_offset") = 0.2,
        py::arg("outlier_sigma") = 0.04, "an ensemble: the field plus i.i.d. noise per voxel");
    m.def(
        "read_field",
        [](const std::filesystem::path& path, const std::string& var, bool allowMissing) {
            FieldReadOptions o;
            o.var = var;
            o.allowMissing = allowMissing;
            return readField(path, o);
        },
        py::arg("path"), py::arg("var") = "", py::arg("allow_missing") = false,
        "allow_missing: NaN/Inf pass, NetCDF fill values read as NaN (build's nan='skip')");
    m.def("write_field", &writeField, py::arg("path"), py::arg("field"));
    m.def(
        "read_ensemble",
        [](const std::vector<std::string>& inputs, const std::string& var,
           const std::string& memberDim, bool allowMissing) {
            EnsembleReadOptions o;
            o.var = var;
            o.memberDim = memberDim;
            o.allowMissing = allowMissing;
            return readEnsemble(inputs, o);
        },
        py::arg("inputs"), py::arg("var") = "", py::arg("member_dim") = "",
        py::arg("allow_missing") = false,
        "allow_missing: NaN/Inf pass, NetCDF fill values read as NaN (build's nan='skip')");
    m.def("write_ensemble", &writeEnsembleNetcdf, py::arg("path"), py::arg("ensemble"));
    m.def("read_model", &readModelVti, py::arg("path"));
    m.def(
        "_read_model_or_field",
        [](const std::filesystem::path& path, const std::string& var) {
            FieldReadOptions o;
            o.var = var;
            return readModelOrField(path, o);
        },
        py::arg("path"), py::arg("var") = "");
    m.def(
        "_regular_axis",
        [](const std::vector<double>& coords, const std::string& what) {
            if (coords.empty()) throw UdvrError(what + " is empty");
            return regularAxis(coords, what);
        },
        py::arg("coords"), py::arg("what"));
    m.def(
        "_check_model", [](const std::string& name) { parseModelKind(name); }, py::arg("name"),
        "raises ValueError (the CLI's message) unless `name` is a model");
    m.def("write_model", &writeModelVti, py::arg("path"), py::arg("model"),
          py::arg("compress") = true);
    m.def("model_from_field", &modelFromField, py::arg("field"));
    m.def("members_model", &membersModel, py::arg("ensemble"),
          "the ensemble as the `members` reference (render/probe model 'members'): its values "
          "held voxel-major, the mean, min and max as a model's");
    m.def("read_transfer_function", &readTransferFunction, py::arg("path"));
    m.def("model_names", [] {
        std::vector<std::string> names;
        for (ModelKind k : allModelKinds()) names.emplace_back(modelName(k));
        return names;
    });
    m.def(
        "models",
        [] {
            py::list rows;
            for (const ModelFamily& f : modelFamilies()) {
                py::list tfKinds;
                if (f.makeKernel || f.realizations) tfKinds.append("1d");
                if (f.makeKernel2D) tfKinds.append("2d");
                if (f.makeBivariate) tfKinds.append("bivariate");
                py::dict row;
                row["name"] = std::string(f.name);
                row["help"] = std::string(f.help);
                row["arrays"] = modelArrayNames(f.arrays);
                row["minmax_arrays"] = modelArrayNames(f.arraysFor(true));
                row["tf_kinds"] = tfKinds;
                row["probe"] = f.makeKernel != nullptr;
                row["realizations"] = f.realizations;
                row["exact_form"] = f.exactForm;
                rows.append(std::move(row));
            }
            return rows;
        },
        "the model table (src/udvr/classify/model_rows.h), one dict per row in table order: "
        "name, help, arrays (what the classification reads: SPEC §7's arrays, 'members' for "
        "an ensemble's members), minmax_arrays (with uniform_width='minmax'), tf_kinds ('1d', "
        "'2d', 'bivariate': the TF kinds it renders with), probe (a distribution at a point), "
        "realizations (rendered as an average of realizations, gmm-mc), exact_form (the "
        "reference evaluation of a fast model)");
    py::class_<Camera>(m, "Camera")
        .def(py::init([](std::array<double, 3> position, std::array<double, 3> focalPoint,
                         std::array<double, 3> viewUp, double viewAngle,
                         std::optional<double> parallelScale) {
                 Camera c;
                 c.position = position;
                 c.focalPoint = focalPoint;
                 c.viewUp = viewUp;
                 c.viewAngleDeg = viewAngle;
                 if (parallelScale) {
                     if (!(*parallelScale > 0.0))
                         throw UdvrError("parallel_scale must be > 0, got " +
                                         std::to_string(*parallelScale));
                     c.parallel = true;
                     c.parallelScale = *parallelScale;
                 }
                 makeCameraFrame(c, 1, 1);  // refuses a degenerate camera now, not at render
                 return c;
             }),
             py::kw_only(), py::arg("position"), py::arg("focal_point"),
             py::arg("view_up") = Camera{}.viewUp, py::arg("view_angle") = kDefaultViewAngleDeg,
             py::arg("parallel_scale") = py::none(),
             "a VTK camera, world units (SPEC §5): perspective with view_angle (degrees, "
             "vertical), orthographic with parallel_scale (half the view height)")
        .def_readwrite("position", &Camera::position)
        .def_readwrite("focal_point", &Camera::focalPoint)
        .def_readwrite("view_up", &Camera::viewUp)
        .def_readwrite("view_angle", &Camera::viewAngleDeg)
        .def_readwrite("parallel", &Camera::parallel)
        .def_readwrite("parallel_scale", &Camera::parallelScale)
        .def_static("default", &defaultCamera, py::arg("bounds"),
                    py::arg("azimuth") = kDefaultAzimuthDeg,
                    py::arg("elevation") = kDefaultElevationDeg, py::arg("zoom") = kDefaultZoom,
                    py::arg("view_angle") = kDefaultViewAngleDeg,
                    "SPEC §5's default camera for a box (xmin,xmax,ymin,ymax,zmin,zmax): what "
                    "`udvr render --tf FILE` uses")
        .def_static(
            "framed",
            [](std::array<double, 6> box, const std::string& view, std::optional<double> azimuth,
               std::optional<double> elevation, double zoom, double viewAngle, double aspect) {
                // As `udvr render --view/--frame` (framing.h): the z-up front view turned to SPEC
                // §5's three-quarter view; an axis view straight along its axis.
                return framedCamera(box, view, azimuth, elevation, zoom, viewAngle, aspect);
            },
            py::arg("box"), py::arg("view") = "", py::arg("azimuth") = py::none(),
            py::arg("elevation") = py::none(), py::arg("zoom") = kDefaultZoom,
            py::arg("view_angle") = kDefaultViewAngleDeg, py::arg("aspect") = 1.0,
            "a camera that frames `box` (e.g. visible_bounds): view '' (z up, front) or "
            "+x|-x|+y|-y|+z|-z")
        .def("__repr__", [](const Camera& c) {
            char text[320];
            std::snprintf(text, sizeof text,
                          "Camera(position=(%g, %g, %g), focal_point=(%g, %g, %g), view_up=(%g, "
                          "%g, %g), %s=%g)",
                          c.position[0], c.position[1], c.position[2], c.focalPoint[0],
                          c.focalPoint[1], c.focalPoint[2], c.viewUp[0], c.viewUp[1], c.viewUp[2],
                          c.parallel ? "parallel_scale" : "view_angle",
                          c.parallel ? c.parallelScale : c.viewAngleDeg);
            return std::string(text);
        });
    m.def(
        "visible_bounds",
        [](const ModelVolume& model, const TransferFunction1D& tf) {
            return visibleBounds(model, tf);
        },
        py::arg("model"), py::arg("tf"),
        "the box of the voxels the TF makes visible (what the CLI's framed camera fits)");
    m.def(
        "visible_bounds",
        [](const ModelVolume& model, const TransferFunction2D& tf) {
            return visibleBounds(model, tf);
        },
        py::arg("model"), py::arg("tf"));

    // The library's option tables (render/render_options.h): Python's keywords are their names
    // with '_' for '-', parsed and checked by the same code as the CLI's flags.
    m.def(
        "render_options",
        [] {
            return optionRows(
                {classificationOptionSpecs(), frameOptionSpecs(), forceOptionSpecs()});
        },
        "(keyword, type, default, range, help) of every option udvr.render takes, as `udvr "
        "render --help` lists them");
    m.def(
        "probe_options", [] { return optionRows({classificationOptionSpecs()}); },
        "(keyword, type, default, range, help) of every option Model.probe takes, as `udvr "
        "probe --help` lists them");
    m.def(
        "_require_tf2_for_second",
        [](bool secondGiven, bool tf2Given) {
            requireTf2ForSecond(secondGiven, tf2Given, "second", "a TransferFunction2D");
        },
        py::arg("second_given"), py::arg("tf2_given"),
        "raises ValueError (the CLI's --second message) when second is given without a 2D TF");
    m.def(
        "_render_settings",
        [](const ModelVolume& model, const py::object& tf,
           const std::vector<std::pair<std::string, std::string>>& given) {
            const RenderOptions options = optionsGiven(
                given, {classificationOptionSpecs(), frameOptionSpecs(), forceOptionSpecs()});
            const auto visibleBox = [&] {
                if (py::isinstance<TransferFunction2D>(tf))
                    return visibleBounds(model, tf.cast<const TransferFunction2D&>());
                return visibleBounds(model, tf.cast<const TransferFunction1D&>());
            };
            std::string note;
            return renderSettingsFromOptions(options, model, visibleBox, note);
        },
        py::arg("model"), py::arg("tf"), py::arg("options"));

    py::class_<RenderSettings>(m, "RenderSettings")
        .def(py::init<>())
        .def_readwrite("width", &RenderSettings::width)
        .def_readwrite("height", &RenderSettings::height)
        .def_readwrite("camera", &RenderSettings::camera)
        .def_readwrite("step", &RenderSettings::step, "world units; 0: half the smallest spacing")
        .def_readwrite("unit_distance", &RenderSettings::unitDistance, "world units; 0: default")
        .def_readwrite("early_exit", &RenderSettings::earlyExit)
        .def_readwrite("background", &RenderSettings::background)
        .def_readwrite("skip_empty", &RenderSettings::skipEmpty)
        .def_readwrite("realizations", &RenderSettings::realizations)
        .def_readwrite("seed", &RenderSettings::seed)
        .def_readwrite("jitter_seed", &RenderSettings::jitterSeed)
        .def_readwrite("uniform_minmax", &RenderSettings::uniformMinMax);
    m.def("_render", &renderArray<TransferFunction1D>, py::arg("model"), py::arg("kind"),
          py::arg("tf"), py::arg("settings"));
    m.def("_render", &renderArray<TransferFunction2D>, py::arg("model"), py::arg("kind"),
          py::arg("tf"), py::arg("settings"));
    m.def(
        "_render_bivariate",
        [](const ModelVolume& first, const ModelVolume& second, const std::string& kind,
           const TransferFunction2D& tf, const RenderSettings& s) {
            const ModelKind k = parseModelKind(kind);
            return imageArray(renderInterruptibly(s, [&](const RenderSettings& settings) {
                return renderBivariate(first, second, k, tf, settings);
            }));
        },
        py::arg("first"), py::arg("second"), py::arg("kind"), py::arg("tf"), py::arg("settings"));

    m.def(
        "_build",
        [](const FloatArray& values, std::array<double, 3> origin, std::array<double, 3> spacing,
           int downsample, int quantiles, int gmm, const std::string& density,
           const std::string& bandwidth, std::optional<double> tailEps, bool gmmGiven,
           bool quantilesGiven, const std::string& source, const py::object& progress,
           const std::vector<double>& levels, double valueStep, const std::string& valueType,
           const std::string& nan) {
            BuildOptions opt;
            opt.nan = parseNanPolicy(nan);
            opt.quantiles = quantiles;
            if (!levels.empty()) {  // as build --quantile-levels: q from their count
                const int q = static_cast<int>(levels.size()) - 1;
                if (quantilesGiven && quantiles != q)
                    UDVR_FAIL("--quantiles " << quantiles << " disagrees with the " << q + 1
                                             << " values of --quantile-levels (q + 1 boundaries)");
                opt.quantiles = q;
                opt.quantileLevels = levels;
            }
            opt.gmmComponents = gmm;
            opt.density = parseDensityEstimate(density);
            opt.bandwidthText = bandwidth;
            if (opt.density == DensityEstimate::Kde) opt.bandwidth = parseBandwidth(bandwidth);
            if (tailEps) {
                if (!(*tailEps > 0.0))
                    UDVR_FAIL("--tail-eps " << *tailEps
                                            << " is out of range; expected 0 < E < 0.5");
                opt.tailEps = *tailEps;
            }
            opt.source = source;
            return buildFromArray(values, origin, spacing, downsample, opt, gmmGiven,
                                  quantilesGiven, progress, valueStep, valueType);
        },
        py::arg("values"), py::arg("origin"), py::arg("spacing"), py::arg("downsample"),
        py::arg("quantiles"), py::arg("gmm"), py::arg("density"), py::arg("bandwidth"),
        py::arg("tail_eps"), py::arg("gmm_given"), py::arg("quantiles_given"), py::arg("source"),
        py::arg("progress"), py::arg("quantile_levels") = std::vector<double>{},
        py::arg("value_step") = 0.0, py::arg("value_type") = "", py::arg("nan") = "error");

    m.def(
        "_default_density", [](bool bricks) { return densityEstimateName(defaultDensity(bricks)); },
        py::arg("bricks"), "build's density estimate when none is given");
    m.def("_probe", &probeAt<TransferFunction1D>, py::arg("model"), py::arg("kind"), py::arg("tf"),
          py::arg("point"), py::arg("options"));
    m.def("_probe", &probeAt<TransferFunction2D>, py::arg("model"), py::arg("kind"), py::arg("tf"),
          py::arg("point"), py::arg("options"));
    m.def(
        "_probe_bivariate",
        [](const ModelVolume& first, const ModelVolume& second, const std::string& kind,
           const TransferFunction2D& tf, std::array<double, 3> point,
           const std::vector<std::pair<std::string, std::string>>& given) {
            const ClassifyOptions o =
                classifyOptionsFrom(optionsGiven(given, {classificationOptionSpecs()}));
            return probeOutput(probeBivariate(first, second, parseModelKind(kind), tf, point, o));
        },
        py::arg("first"), py::arg("second"), py::arg("kind"), py::arg("tf"), py::arg("point"),
        py::arg("options"));
    m.def("index_from_world", &indexFromWorld, py::arg("grid"), py::arg("world"),
          py::arg("what") = "world point",
          "index-space point of a world position (ValueError outside the grid)");

    m.def(
        "rmse",
        [](const FloatArray& model, const FloatArray& truth) {
            return imageRmse(imageFromArray(model, "model image"),
                             imageFromArray(truth, "truth image"));
        },
        py::arg("model"), py::arg("truth"),
        "SPEC §6: sqrt(mean over pixels of |mean(RGB) - mean(RGB of truth)|^2), as `udvr "
        "compare`");
    m.def(
        "read_png_text",
        [](const std::filesystem::path& path) {
            py::dict out;
            for (const auto& [key, value] : readPngText(path)) out[py::str(key)] = value;
            return out;
        },
        py::arg("path"),
        "a PNG's text chunks as a dict: `udvr render` records its model, TF, camera, size and "
        "source (keys udvr:model, udvr:tf, udvr:tf-range, udvr:camera, udvr:size, udvr:source)");
    m.def(
        "read_image", [](const std::filesystem::path& path) { return imageArray(readImage(path)); },
        py::arg("path"), "a .png, .npy or .pfm image as an (H, W, 4) float32 array in [0, 1]");
    m.def(
        "difference_image",
        [](const FloatArray& model, const FloatArray& truth, double maxDiff) {
            return imageArray(differenceImage(imageFromArray(model, "model image"),
                                              imageFromArray(truth, "truth image"), maxDiff));
        },
        py::arg("model"), py::arg("truth"), py::arg("max_diff") = 0.0,
        "the blue-yellow difference image of `udvr compare --diff` as an (H, W, 4) array; "
        "max_diff <= 0: the largest difference is full yellow");

    m.def("experiment_names", &experimentNames);
    m.def(
        "_experiment",
        [](const std::string& name, const std::filesystem::path& out, bool quick,
           const std::filesystem::path& tfDir, const std::filesystem::path& dataDir, int dims,
           int members, int imageSize, int realizations, bool log) {
            ExperimentOptions o;
            o.quick = quick;
            o.tfDir = tfDir;
            o.dataDir = dataDir;
            o.dims = dims;
            o.members = members;
            o.imageSize = imageSize;
            o.realizations = realizations;
            o.log = log;
            std::vector<ExperimentResult> results;
            {
                py::gil_scoped_release release;
                results = runExperiments(name, out, o);
            }
            py::list list;
            for (const ExperimentResult& r : results) {
                py::dict d;
                d["name"] = r.name;
                d["dir"] = r.dir;
                // The rows as results.json holds them (one writer, the same keys).
                d["rows"] = py::module_::import("json").attr("loads")(resultsToJson(r.rows));
                d["files"] = r.files;
                d["seconds"] = r.seconds;
                list.append(d);
            }
            return list;
        },
        py::arg("name"), py::arg("out"), py::arg("quick"), py::arg("tf_dir"), py::arg("data_dir"),
        py::arg("dims"), py::arg("members"), py::arg("image_size"), py::arg("realizations"),
        py::arg("log"));
}
