#include "udvr/data/synthetic.h"

#include <cmath>

#include "udvr/util/check.h"
#include "udvr/util/parallel.h"
#include "udvr/util/text_parse.h"

namespace udvr {
namespace {

// Sample f(x,y,z) in world coordinates over the box [lo, hi] per axis at grid points.
template <class F>
ScalarField sampleBox(const char* name, int nx, int ny, int nz, const double lo[3],
                      const double hi[3], F f) {
    if (nx < 2 || ny < 2 || nz < 2)
        UDVR_FAIL("--dims must be at least 2 per axis, got " << nx << "," << ny << "," << nz);
    ScalarField field;
    field.name = name;
    field.grid.dims = {nx, ny, nz};
    const int n[3] = {nx, ny, nz};
    for (int a = 0; a < 3; ++a) {
        field.grid.origin[a] = lo[a];
        field.grid.spacing[a] = (hi[a] - lo[a]) / (n[a] - 1);
    }
    field.values.resize(field.grid.pointCount());
    const Grid3& g = field.grid;
    parallelForChunks(static_cast<std::size_t>(nz), 1, [&](std::size_t k0, std::size_t k1) {
        for (std::size_t k = k0; k < k1; ++k) {
            const double z = g.world(2, static_cast<double>(k));
            for (int j = 0; j < ny; ++j) {
                const double y = g.world(1, j);
                for (int i = 0; i < nx; ++i) {
                    field.values[g.index(i, j, static_cast<int>(k))] =
                        static_cast<float>(f(g.world(0, i), y, z));
                }
            }
        }
    });
    return field;
}

}  // namespace

ScalarField makeTangle(int nx, int ny, int nz) {
    const double lo[3] = {-2.5, -2.5, -2.5}, hi[3] = {2.5, 2.5, 2.5};
    return sampleBox("tangle", nx, ny, nz, lo, hi, [](double x, double y, double z) {
        auto g = [](double t) { return t * t * t * t - 5.0 * t * t; };
        return g(x) + g(y) + g(z) + 11.8;
    });
}

ScalarField makeTeardrop(int nx, int ny, int nz) {
    const double lo[3] = {-1.1, -0.6, -0.6}, hi[3] = {0.1, 0.6, 0.6};
    return sampleBox("teardrop", nx, ny, nz, lo, hi, [](double x, double y, double z) {
        const double x4 = x * x * x * x;
        return 100.0 * (0.5 * x4 * x + 0.5 * x4 - y * y - z * z);
    });
}

ScalarField makeNestedSpheres(int nx, int ny, int nz) {
    const double lo[3] = {-1, -1, -1}, hi[3] = {1, 1, 1};
    return sampleBox("spheres", nx, ny, nz, lo, hi, [](double x, double y, double z) {
        const double r = std::sqrt(x * x + y * y + z * z);
        const double radii[4] = {0.2, 0.4, 0.6, 0.8};
        const double halfThickness = 0.03;
        for (int s = 0; s < 4; ++s)
            if (std::abs(r - radii[s]) <= halfThickness) return 25.0 * (s + 1);
        return 0.0;
    });
}

ScalarField makeMarschnerLobb(int nx, int ny, int nz) {
    const double lo[3] = {-1, -1, -1}, hi[3] = {1, 1, 1};
    return sampleBox("marschner_lobb", nx, ny, nz, lo, hi, [](double x, double y, double z) {
        const double pi = 3.14159265358979323846, fM = 6.0, alpha = 0.25;
        const double r = std::sqrt(x * x + y * y);
        const double rho = std::cos(2.0 * pi * fM * std::cos(pi * r / 2.0));
        return (1.0 - std::sin(pi * z / 2.0) + alpha * (1.0 + rho)) / (2.0 * (1.0 + alpha));
    });
}

const std::vector<std::string>& syntheticFieldNames() {
    static const std::vector<std::string> names{"tangle", "teardrop", "spheres", "marschner-lobb"};
    return names;
}

ScalarField makeSyntheticField(std::string_view name, int nx, int ny, int nz) {
    if (name == "tangle") return makeTangle(nx, ny, nz);
    if (name == "teardrop") return makeTeardrop(nx, ny, nz);
    if (name == "spheres" || name == "nested-spheres") return makeNestedSpheres(nx, ny, nz);
    if (name == "marschner-lobb") return makeMarschnerLobb(nx, ny, nz);
    UDVR_FAIL(
        "unknown field '" << clipForMessage(name) << "'"
                          << didYouMean(name, {"tangle", "teardrop", "spheres", "marschner-lobb"})
                          << "; expected one of: tangle, teardrop, spheres, marschner-lobb");
}

}  // namespace udvr
