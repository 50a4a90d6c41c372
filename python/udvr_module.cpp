// The `udvr` Python module: a thin pybind11 layer over the library (no algorithm of its own).
// Arrays cross as NumPy arrays in C order (z, y, x), so x is fastest as in SPEC §1.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cmath>
#include <cstring>
#include <optional>

#include "udvr/classify/model_kind.h"
#include "udvr/data/noise.h"
#include "udvr/data/synthetic.h"
#include "udvr/io/ensemble_io.h"
#include "udvr/io/field_io.h"
#include "udvr/io/image.h"
#include "udvr/io/model_io.h"
#include "udvr/io/transfer_function_io.h"
#include "udvr/render/render.h"
#include "udvr/stats/model_volume.h"
#include "udvr/util/build_info.h"
#include "udvr/util/check.h"
#include "udvr/util/parallel.h"

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

Grid3 gridFromShape(const FloatArray& a, int leadingDims) {
    if (a.ndim() != 3 + leadingDims)
        throw UdvrError("expected an array of " + std::to_string(3 + leadingDims) + " dimensions");
    Grid3 g;
    g.dims = {static_cast<int>(a.shape(2 + leadingDims)),
              static_cast<int>(a.shape(1 + leadingDims)), static_cast<int>(a.shape(leadingDims))};
    return g;
}

// A field or an ensemble (T) from an array of (leadingDims axes, Z, Y, X), placed in the world.
template <class T>
T gridded(const FloatArray& values, int leadingDims, const std::array<double, 3>& origin,
          const std::array<double, 3>& spacing, std::string name) {
    T t;
    t.grid = gridFromShape(values, leadingDims);
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

ModelVolume modelFromArrays(
    const FloatArray& mean, const std::optional<FloatArray>& stddev,
    const std::optional<FloatArray>& min, const std::optional<FloatArray>& max,
    const std::optional<FloatArray>& quantiles, const std::optional<FloatArray>& iqr,
    const std::optional<FloatArray>& gmm, std::array<double, 3> origin,
    std::array<double, 3> spacing, const std::optional<std::array<double, 6>>& bounds,
    const std::optional<double>& fullResMinSpacing, int downsample, int samplesPerVoxel,
    const std::string& density, const std::string& source) {
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
    return mv;
}

}  // namespace

PYBIND11_MODULE(udvr, m) {
    m.doc() = "udvr: direct volume rendering of uncertain data (Athawale et al., TVCG 2021)";
    // e.g. "target native: AVX-512, 16-float lanes in 1 register of 512 bits" (as `udvr --version`)
    m.attr("__build__") = std::string(udvr::build::buildDescription());
    py::register_exception<UdvrError>(m, "UdvrError", PyExc_ValueError);

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
        .def(py::init([](const FloatArray& values, std::array<double, 3> origin,
                         std::array<double, 3> spacing, std::string name) {
                 return gridded<ScalarField>(values, 0, origin, spacing, std::move(name));
             }),
             py::arg("values"), py::arg("origin") = std::array<double, 3>{0, 0, 0},
             py::arg("spacing") = std::array<double, 3>{1, 1, 1}, py::arg("name") = "value",
             "a field from a (Z, Y, X) array")
        .def_readwrite("grid", &ScalarField::grid)
        .def_readwrite("name", &ScalarField::name)
        .def_property_readonly(
            "values", [](const ScalarField& f) { return voxelArray(f.grid, f.values, 1); },
            "the values as a (Z, Y, X) float32 array (a copy)");

    py::class_<Ensemble>(m, "Ensemble")
        .def(py::init([](const FloatArray& values, std::array<double, 3> origin,
                         std::array<double, 3> spacing, std::string name) {
                 Ensemble e = gridded<Ensemble>(values, 1, origin, spacing, std::move(name));
                 e.members = static_cast<int>(values.shape(0));
                 return e;
             }),
             py::arg("values"), py::arg("origin") = std::array<double, 3>{0, 0, 0},
             py::arg("spacing") = std::array<double, 3>{1, 1, 1}, py::arg("name") = "value",
             "an ensemble from a (members, Z, Y, X) array")
        .def_readwrite("grid", &Ensemble::grid)
        .def_readonly("members", &Ensemble::members)
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
            "the members as a (members, Z, Y, X) float32 array (a copy)");

    py::class_<ModelVolume>(m, "Model")
        .def(py::init(&modelFromArrays), py::arg("mean"), py::kw_only(),
             py::arg("stddev") = py::none(), py::arg("min") = py::none(),
             py::arg("max") = py::none(), py::arg("quantiles") = py::none(),
             py::arg("iqr") = py::none(), py::arg("gmm") = py::none(),
             py::arg("origin") = std::array<double, 3>{0, 0, 0},
             py::arg("spacing") = std::array<double, 3>{1, 1, 1}, py::arg("bounds") = py::none(),
             py::arg("full_res_min_spacing") = py::none(), py::arg("downsample") = 0,
             py::arg("samples_per_voxel") = 0, py::arg("density") = "empirical",
             py::arg("source") = "python",
             "a model from NumPy arrays of shape (Z, Y, X[, components]): mean (required), "
             "stddev, min, max (default: mean), quantiles (Z,Y,X,q+1), iqr (Z,Y,X,2), gmm "
             "(Z,Y,X,3K: pi_1..pi_K, mu_1..mu_K, sigma_1..sigma_K); bounds (xmin,xmax,ymin,ymax,"
             "zmin,zmax) and full_res_min_spacing default to the model grid's")
        .def_readwrite("grid", &ModelVolume::grid)
        .def_readonly("quantile_count", &ModelVolume::quantileCount)
        .def_readonly("gmm_components", &ModelVolume::gmmComponents)
        .def_readonly("density", &ModelVolume::density)
        .def_readonly("samples_per_voxel", &ModelVolume::samplesPerVoxel)
        .def_readonly("downsample", &ModelVolume::downsample)
        .def_readonly("bounds", &ModelVolume::bounds)
        .def_readonly("full_res_min_spacing", &ModelVolume::fullResMinSpacing)
        .def(
            "array",
            [](const ModelVolume& mv, const std::string& name) {
                if (name == "mean") return voxelArray(mv.grid, mv.mean, 1);
                if (name == "stddev") return voxelArray(mv.grid, mv.stddev, 1);
                if (name == "min") return voxelArray(mv.grid, mv.min, 1);
                if (name == "max") return voxelArray(mv.grid, mv.max, 1);
                if (name == "quantiles")
                    return voxelArray(mv.grid, mv.quantiles, mv.quantileCount + 1);
                if (name == "iqr") return voxelArray(mv.grid, mv.iqr, 2);
                if (name == "gmm") return voxelArray(mv.grid, mv.gmm, 3 * mv.gmmComponents);
                throw UdvrError("unknown model array '" + name +
                                "'; expected mean, stddev, min, max, quantiles, iqr or gmm");
            },
            py::arg("name"), "a per-voxel array as (Z, Y, X[, components])");

    py::class_<TransferFunction1D>(m, "TransferFunction")
        .def("classify", &TransferFunction1D::classify)
        .def("domain", &TransferFunction1D::domain);
    py::class_<Rgba>(m, "Rgba")
        .def_readonly("r", &Rgba::r)
        .def_readonly("g", &Rgba::g)
        .def_readonly("b", &Rgba::b)
        .def_readonly("a", &Rgba::a)
        .def("__iter__",
             [](const Rgba& c) { return py::iter(py::make_tuple(c.r, c.g, c.b, c.a)); });

    m.def("set_threads", &setThreadCount, py::arg("threads"), "worker threads (0 = all cores)");
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
        [](const std::filesystem::path& path, const std::string& var) {
            FieldReadOptions o;
            o.var = var;
            return readField(path, o);
        },
        py::arg("path"), py::arg("var") = "");
    m.def("write_field", &writeField, py::arg("path"), py::arg("field"));
    m.def(
        "read_ensemble",
        [](const std::vector<std::string>& inputs, const std::string& var,
           const std::string& memberDim) {
            EnsembleReadOptions o;
            o.var = var;
            o.memberDim = memberDim;
            return readEnsemble(inputs, o);
        },
        py::arg("inputs"), py::arg("var") = "", py::arg("member_dim") = "");
    m.def("write_ensemble", &writeEnsembleNetcdf, py::arg("path"), py::arg("ensemble"));
    m.def("read_model", &readModelVti, py::arg("path"));
    m.def("write_model", &writeModelVti, py::arg("path"), py::arg("model"));
    m.def("model_from_field", &modelFromField, py::arg("field"));
    m.def("read_transfer_function", &readTransferFunction, py::arg("path"));
    m.def("model_names", [] {
        std::vector<std::string> names;
        for (ModelKind k : allModelKinds()) names.emplace_back(modelName(k));
        return names;
    });
    m.def(
        "render",
        [](const ModelVolume& model, const std::string& kind, const TransferFunction1D& tf,
           std::array<int, 2> size, double azimuth, double elevation, double zoom, double step,
           int realizations, std::uint64_t seed) {
            RenderSettings s;
            s.width = size[0];
            s.height = size[1];
            s.camera = defaultCamera(model.bounds, azimuth, elevation, zoom);
            s.step = step;
            s.realizations = realizations;
            s.seed = seed;
            ModelKind k = parseModelKind(kind);
            ImageRgba img;
            {
                py::gil_scoped_release release;
                img = renderVolume(model, k, tf, s);
            }
            FloatArray a({static_cast<py::ssize_t>(img.height), static_cast<py::ssize_t>(img.width),
                          py::ssize_t{4}});
            std::memcpy(a.mutable_data(), img.rgba.data(), img.rgba.size() * sizeof(float));
            return a;
        },
        py::arg("model"), py::arg("kind"), py::arg("tf"),
        py::arg("size") = std::array<int, 2>{512, 512}, py::arg("azimuth") = 30.0,
        py::arg("elevation") = 20.0, py::arg("zoom") = 1.0, py::arg("step") = 0.0,
        py::arg("realizations") = 200, py::arg("seed") = 1,
        "render with the default camera; returns an (H, W, 4) float32 RGBA array");
}
