#include "udvr/classify/probe.h"

#include <algorithm>
#include <cmath>
#include <tuple>
#include <type_traits>

#include "udvr/classify/joint_distribution.h"
#include "udvr/classify/point_distribution.h"
#include "udvr/stats/model_volume.h"

namespace udvr {
namespace {

using nlohmann::json;

constexpr int kCdfSamples = 2048;

// The probe's plot of a distribution (SPEC §8 --plot): its point masses, and the CDF of its
// continuous part sampled over its support (normals to μ ± 4σ) padded by 5 % (a point: ± 0.5).
ProbeDistribution plotOf(const PointDistribution& dist) {
    ProbeDistribution d;
    std::tie(d.lo, d.hi) = dist.support(4.0);
    for (const auto& a : dist.atoms) {
        d.atoms.push_back(a.x);
        d.atomMass.push_back(a.mass);
    }
    d.continuousMass = dist.continuousMass();
    const double w = d.hi - d.lo;
    if (w > 0.0) {
        d.lo -= 0.05 * w;
        d.hi += 0.05 * w;
    } else {
        d.lo -= 0.5;
        d.hi += 0.5;
    }
    if (d.continuousMass > 0.0) {
        for (int i = 0; i <= kCdfSamples; ++i)
            d.cdfX.push_back(d.lo + (d.hi - d.lo) * i / kCdfSamples);
        d.cdfY = dist.continuousCdf(d.lo, d.hi, kCdfSamples);
    }
    return d;
}

// The plot as JSON ("plot", what `udvr serve`'s page draws): the continuous part's density as
// kPlotBins averages ΔCDF/Δx over even bins of [lo, hi] (none without a continuous part) and
// the point masses [x, mass].
constexpr int kPlotBins = 256;
static_assert(kCdfSamples % kPlotBins == 0);

json plotJson(const ProbeDistribution& d) {
    json density = json::array();
    if (!d.cdfY.empty()) {
        const int per = kCdfSamples / kPlotBins;
        const double width = (d.hi - d.lo) / kPlotBins;
        for (int b = 0; b < kPlotBins; ++b)
            density.push_back((d.cdfY[(b + 1) * per] - d.cdfY[b * per]) / width);
    }
    json atoms = json::array();
    for (std::size_t i = 0; i < d.atoms.size(); ++i) atoms.push_back({d.atoms[i], d.atomMass[i]});
    return {{"lo", d.lo}, {"hi", d.hi}, {"density", density}, {"atoms", atoms}};
}

/// The model's levels t_0 … t_{count−1} (uneven levels only: levels.levels is set).
std::vector<double> levelsOf(const QuantileLevels& levels, int count) {
    return {levels.levels, levels.levels + count};
}

// What probe reports of a model's parameters at a cell (SPEC §8), next to its distribution: the
// kernel's reconstruction (reconstruct<double>, the object the plot and the point masses listed
// here come from, distributionAt), one overload per distribution type (distributions.h) with
// parameters to print. A new model over an existing distribution type needs nothing here. Only
// the quantile-range family is read from its kernel: its JSON lists the model's whole boundary
// vector, of which the distribution holds the population's window; `family` tells those apart.
struct Describe {
    const ModelFamily& family;
    const Cell<double>& cell;
    const PointDistribution& dist;
    json& j;

    template <class Kernel>
    void operator()(const Kernel& k) const {
        k.template reconstruct<double>(cell, true, [&](const auto& d) { parameters(d); });
    }
    void operator()(const QuantileRangeKernel& k) const {
        std::vector<double> b(static_cast<std::size_t>(k.stride));
        for (int i = 0; i < k.stride; ++i)
            b[i] = boundaryAt<double>(k.geometry, k.boundaries, k.stride, i, cell, true);
        j["boundaries"] = b;
        if (family.population.second > family.population.first) j["population"] = {k.j0, k.j1};
        if (k.levels.levels) j["levels"] = levelsOf(k.levels, k.stride);
    }

  private:
    /// A distribution without parameters of its own to print (the mean field's point mass):
    /// its distribution says it all. Only the types listed here: a new distribution type is a
    /// compile error until it gets an overload (or is listed as having none).
    template <class D>
    void parameters(const D&) const {
        static_assert(std::is_same_v<D, PointMass<double>>,
                      "probe: give this distribution type a Describe::parameters overload, or "
                      "list it as one without parameters of its own");
    }
    void parameters(const NormalDistribution<double>& d) const {
        j["mean"] = d.mu;
        j["stddev"] = d.sigma;
    }
    void parameters(const CornerBoxSpline<double>& d) const {
        json terms = json::array();
        for (int c = 0; c < 8; ++c) {
            if (d.w[c] == 0.0) continue;
            terms.push_back(
                {{"weight", d.w[c]}, {"low", d.w[c] * d.lo[c]}, {"high", d.w[c] * d.hi[c]}});
        }
        const UniformSum u = d.sum();
        j["terms"] = terms;
        j["mean"] = u.mean();
        j["stddev"] = std::sqrt(u.variance());
        j["low"] = u.shift;
        j["high"] = u.shift + u.total;
    }
    void parameters(const NormalMixture<double>& d) const {
        j["weights"] = std::vector<double>(d.pi, d.pi + d.k);
        j["means"] = std::vector<double>(d.mu, d.mu + d.k);
        j["sigmas"] = std::vector<double>(d.sigma, d.sigma + d.k);
    }
    template <class Boundary, class Width>
    void parameters(const QuantileMidpoints<double, Boundary, Width>& d) const {
        std::vector<double> b(static_cast<std::size_t>(d.q) + 1);
        for (int i = 0; i <= d.q; ++i) b[i] = d.boundary(i);
        j["boundaries"] = b;
        if (d.levels.levels) j["levels"] = levelsOf(d.levels, d.q + 1);
        // Eq. 5's point masses: the midpoints m_j and their weights p_j, as the kernel weighs.
        std::vector<double> mids, probs;
        for (const auto& a : dist.atoms) {
            mids.push_back(a.x);
            probs.push_back(a.mass);
        }
        j["midpoints"] = mids;
        j["probabilities"] = probs;
    }
    template <class Values>
    void parameters(const EqualMasses<double, Values>& d) const {
        // The members' values at the point, each a point mass 1/n (the TF is averaged over them).
        std::vector<double> f;
        for (const auto& a : dist.atoms) f.push_back(a.x);
        double mean = 0.0, ss = 0.0;
        for (double x : f) mean += x;
        mean /= d.n;
        for (double x : f) ss += (x - mean) * (x - mean);
        const auto [lo, hi] = std::minmax_element(f.begin(), f.end());
        j["members"] = d.n;
        j["member_values"] = f;
        j["min"] = *lo;
        j["max"] = *hi;
        j["mean"] = mean;
        j["stddev"] = d.n > 1 ? std::sqrt(ss / (d.n - 1)) : 0.0;  // ddof = 1, as SPEC §2's σ
    }
};

// The distribution of a 1D kernel at a cell: its JSON (Describe) and its plot.
template <class Kernel>
void describeDistribution(const ModelFamily& family, const Kernel& k, const Cell<double>& cell,
                          ProbeResult& r) {
    PointDistribution dist;
    distributionAt(k, cell, dist);
    Describe{family, cell, dist, r.json}(k);
    r.distribution = plotOf(dist);
    r.json["plot"] = plotJson(r.distribution);
}

}  // namespace

namespace {

// The cell of an index-space probe point (inside the grid, else UdvrError) and the SPEC §8
// fields every probe prints: model, point, world, grid_dims, corners, value.
Cell<double> probeCell(const ModelVolume& model, const ModelFamily& family,
                       const std::array<double, 3>& point, json& j) {
    if (family.realizations)
        UDVR_FAIL("model '" << family.name
                            << "' is defined by Monte Carlo realizations of whole images; probe "
                               "'gmm-ordered' for the mixture at a point");
    for (int a = 0; a < 3; ++a)
        if (!(point[a] >= 0.0 && point[a] <= model.grid.dims[a] - 1))
            UDVR_FAIL("--point " << point[0] << "," << point[1] << "," << point[2]
                                 << " is outside the grid: index coordinates must lie in [0,"
                                 << model.grid.dims[0] - 1 << "]x[0," << model.grid.dims[1] - 1
                                 << "]x[0," << model.grid.dims[2] - 1 << "]");
    const CellGeometry geometry(model.grid);
    const Cell<double> cell =
        cellAt<double>(geometry, static_cast<float>(point[0]), static_cast<float>(point[1]),
                       static_cast<float>(point[2]));
    j["model"] = std::string(family.name);
    j["point"] = {point[0], point[1], point[2]};
    j["world"] = worldFromIndex(model.grid, point);
    j["grid_dims"] = model.grid.dims;
    double weights[8];
    trilinearWeights(cell, weights);
    json corners = json::array();
    for (int c = 0; c < 8; ++c)
        if (weights[c] > 0.0)
            corners.push_back(
                {{"voxel", cornerVoxel(geometry, cell.base, c)}, {"weight", weights[c]}});
    j["corners"] = corners;
    if (!model.mean.empty()) j["value"] = trilinear(geometry, model.mean.data(), 1, cell, true);
    return cell;
}

void setExpected(ProbeResult& r, const double v[4]) {
    r.expected = Rgba{static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2]),
                      static_cast<float>(v[3])};
    r.json["expected_rgba"] = {r.expected.r, r.expected.g, r.expected.b, r.expected.a};
}

// G's mean and standard deviation at a cell (SPEC §9) from the kernel's joint distribution
// (JointMoments); the covariance of (X, G) where the distribution is a bivariate normal or box
// spline; the polyline of the quantile models, whose G SPEC §9 describes by the quantile
// population (uniform within each quantile, Eq. 2) for quantile-mean too.
template <class Kernel2D>
void describeGradient(const Kernel2D& k, const Cell<double>& cell, json& j) {
    JointMoments m;
    if constexpr (std::is_same_v<Kernel2D, Quantile2DKernel>) {
        Quantile2DKernel population = k;
        population.quantileMean = false;
        JointPointDistribution d;
        jointDistributionAt(population, cell, d);
        std::vector<double> x, g;
        for (const auto& s : d.segments) {
            if (x.empty()) {
                x.push_back(s.xa);
                g.push_back(s.ga);
            }
            x.push_back(s.xb);
            g.push_back(s.gb);
            m.segment(s.xa, s.ga, s.xb, s.gb, s.mass);
        }
        j["polyline"] = {{"x", x}, {"g", g}};
    } else {
        jointDistributionAt(k, cell, m);
    }
    j["gradient_magnitude"] = {{"mean", m.mg}, {"stddev", std::sqrt(m.varG())}};
    if constexpr (std::is_same_v<Kernel2D, Gaussian2DKernel> ||
                  std::is_same_v<Kernel2D, Uniform2DKernel>)
        j["covariance"] = {{m.varX(), m.covXG()}, {m.covXG(), m.varG()}};
    if constexpr (std::is_same_v<Kernel2D, Uniform2DKernel>) {
        // The box spline itself, (X, G) = center + Σ_i t_i·direction_i, t_i ~ U[−1, 1] (data
        // units): what the 2D uniform's expectation integrates over.
        JointPointDistribution d;
        jointDistributionAt(k, cell, d);
        if (d.boxSplines.size() == 1) {
            const BoxSpline2& b = d.boxSplines.front().piece;
            json directions = json::array();
            for (int i = 0; i < b.n; ++i) directions.push_back({b.d[i].a, b.d[i].b});
            j["box_spline"] = {{"center", {b.cx, b.cg}}, {"directions", directions}};
        }
    }
}

}  // namespace

ProbeResult probeModel(const ModelVolume& model, ModelKind kind, const TransferFunction1D& tf,
                       const std::array<double, 3>& point, const ClassifyOptions& options) {
    const ModelFamily& family = modelFamily(kind);
    ProbeResult r{kind, point, {}, json::object(), {}};
    const Cell<double> cell = probeCell(model, family, point, r.json);
    withKernel(model, kind, tf, options, [&](const auto& k) {
        double v[4];
        k.finish(k.template load<double>(cell, true), v);
        setExpected(r, v);
        describeDistribution(family, k, cell, r);
    });
    return r;
}

namespace {

// The voxels a 2D probe at `cell` reads: the cell's corners and their gradient neighbours,
// [base − 1, base + 2] per axis within the grid. Grid gradients of the cut-out at the corners
// are the whole model's (each corner's stencil sees the same neighbours and the same grid
// ends), so a probe costs O(1), not gradients of the whole volume. `shift` gets the cut-out's
// offset in index space.
ModelVolume probeNeighbourhood(const ModelVolume& m, const Cell<double>& cell,
                               std::array<int, 3>& shift) {
    const std::array<int, 3> base = voxelIndices(CellGeometry(m.grid), cell.base);
    int lo[3], hi[3];
    ModelVolume c = m;  // scalars and field data; the arrays are replaced below
    for (int a = 0; a < 3; ++a) {
        lo[a] = std::max(base[a] - 1, 0);
        hi[a] = std::min(base[a] + 2, m.grid.dims[a] - 1);
        shift[a] = lo[a];
        c.grid.dims[a] = hi[a] - lo[a] + 1;
        c.grid.origin[a] = m.grid.world(a, lo[a]);
    }
    const auto cut = [&](const std::vector<float>& from, std::size_t per) {
        std::vector<float> out;
        if (from.empty()) return out;
        for (int k = lo[2]; k <= hi[2]; ++k)
            for (int j = lo[1]; j <= hi[1]; ++j) {
                const std::size_t v = m.grid.index(lo[0], j, k);
                out.insert(out.end(), from.begin() + static_cast<std::ptrdiff_t>(v * per),
                           from.begin() + static_cast<std::ptrdiff_t>((v + c.grid.dims[0]) * per));
            }
        return out;
    };
    for (const ModelFileArray& a : kModelFileArrays)
        c.*a.values = cut(m.*a.values, static_cast<std::size_t>(a.floatsPerVoxel(m)));
    c.members = cut(m.members, static_cast<std::size_t>(m.memberCount));
    return c;
}

}  // namespace

ProbeResult probeModel(const ModelVolume& model, ModelKind kind, const TransferFunction2D& tf,
                       const std::array<double, 3>& point, const ClassifyOptions& options) {
    const ModelFamily& family = modelFamily(kind);
    tf.validate();
    ProbeResult r{kind, point, {}, json::object(), {}};
    const Cell<double> cell = probeCell(model, family, point, r.json);
    checkModelHasArrays(model, kind, options);
    checkModelHasArrays(model, ModelKind::Mean, options);
    // Classify in the cut-out around the cell, its zero-width thresholds scaled by the whole
    // model's data range.
    std::array<int, 3> shift{};
    const ModelVolume local = probeNeighbourhood(model, cell, shift);
    ClassifyOptions localOptions = options;
    if (localOptions.dataSpan <= 0.0) {
        const auto range = modelDataRange(model);
        localOptions.dataSpan = range.second - range.first;
    }
    // The same cell (base and fractions) in the cut-out.
    const std::array<int, 3> base = voxelIndices(CellGeometry(model.grid), cell.base);
    const Cell<double> localCell{static_cast<std::int64_t>(local.grid.index(
                                     base[0] - shift[0], base[1] - shift[1], base[2] - shift[2])),
                                 cell.fx, cell.fy, cell.fz};
    withKernel2D(local, kind, tf, localOptions, [&](const auto& k) {
        double v[4];
        k.finish(k.template load<double>(localCell, true), v);
        setExpected(r, v);
        double y[3];
        k.template meanGradientAt<double>(localCell, true, y);
        r.json["gradient"] = {y[0], y[1], y[2]};
        describeGradient(k, localCell, r.json);
    });
    // The value's distribution is the 1D model's (the TF plays no part in it).
    withKernel(model, kind, reconstructionOnlyTf(), options,
               [&](const auto& k) { describeDistribution(family, k, cell, r); });
    return r;
}

ProbeResult probeBivariate(const ModelVolume& first, const ModelVolume& second, ModelKind kind,
                           const TransferFunction2D& tf, const std::array<double, 3>& point,
                           const ClassifyOptions& options) {
    const ModelFamily& family = modelFamily(kind);
    tf.validate();
    checkSameGrid(first, second);
    ProbeResult r{kind, point, {}, json::object(), {}};
    const Cell<double> cell = probeCell(first, family, point, r.json);
    withKernelBivariate(first, second, kind, tf, options, [&](const auto& k) {
        double v[4];
        k.finish(k.template load<double>(cell, true), v);
        setExpected(r, v);
        DistributionMoments y;
        if constexpr (std::is_same_v<std::decay_t<decltype(k)>, Bivariate2DKernel>)
            y = k.secondAt(cell);
        else
            y.point(trilinear(k.geometry, k.second, 1, cell, true), 1.0);
        const CellGeometry geometry(second.grid);
        r.json["second"] = {{"value", trilinear(geometry, second.mean.data(), 1, cell, true)},
                            {"mean", y.mean()},
                            {"stddev", y.stddev()}};
        r.json["gradient_magnitude"] = {{"mean", y.mean()}, {"stddev", y.stddev()}};
    });
    // The first field's distribution is its 1D model's.
    withKernel(first, kind, reconstructionOnlyTf(), options,
               [&](const auto& k) { describeDistribution(family, k, cell, r); });
    return r;
}

std::array<double, 3> worldFromIndex(const Grid3& g, const std::array<double, 3>& index) {
    std::array<double, 3> w{};
    for (int a = 0; a < 3; ++a) w[a] = g.origin[a] + index[a] * g.spacing[a];
    return w;
}

std::array<double, 3> indexFromWorld(const Grid3& g, const std::array<double, 3>& world,
                                     const std::string& what) {
    std::array<double, 3> p{};
    for (int a = 0; a < 3; ++a) {
        p[a] = (world[a] - g.origin[a]) / g.spacing[a];
        const double top = g.origin[a] + (g.dims[a] - 1) * g.spacing[a];
        if (!(p[a] >= 0.0 && p[a] <= g.dims[a] - 1))
            UDVR_FAIL(what << " is outside the input's grid: "
                           << "xyz"[a] << " must lie in [" << g.origin[a] << ", " << top << "]");
    }
    return p;
}

}  // namespace udvr
