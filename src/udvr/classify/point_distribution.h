#pragma once
// A model's distribution at a point (SPEC §3), apart from the expectation of any TF over it
// (docs/architecture.md, "Distributions and expectations"). DistributionAt reconstructs the
// random variable of each 1D model's kernel once, in double, as pieces of probability mass into
// a DistributionSink: point masses, uniform pieces (Eq. 2's quantiles), normals and box splines.
// Its consumers are the sinks:
//   - PointDistribution stores the pieces: probe's JSON and plot (probe.cpp) and expectedTfOver,
//     the expectation of a 1D TF over any distribution (Eq. 3);
//   - AxisMoments (expected_tf2_bivariate.h): per-raster-cell moments, for a bivariate TF2;
//   - DistributionMoments: mean and variance.
// The render kernels' lane bodies (model_kernels.h) are the fast path of the same definitions;
// probe_test.cpp holds every kernel's classification to expectedTfOver of its distribution.
#include <algorithm>
#include <cmath>
#include <concepts>
#include <utility>
#include <variant>
#include <vector>

#include "udvr/classify/model_kernels.h"
#include "udvr/reconstruct/box_spline.h"
#include "udvr/util/normal_cdf.h"

namespace udvr {

/// What receives a distribution (data units; masses sum to 1 over the pieces of one point):
/// point(x, m): mass m at x; uniform(a, b, m): m spread evenly over [a, b], a < b;
/// normal(μ, σ, m): m × N(μ, σ²), σ > 0; boxSpline(u, m): m × the density of a sum of uniforms
/// (u.n ≥ 1).
template <class S>
concept DistributionSink = requires(S& s, double x, const UniformSum& u) {
    s.point(x, x);
    s.uniform(x, x, x);
    s.normal(x, x, x);
    s.boxSpline(u, x);
};

/// Eq. 5's masses of quantiles 0 … q − 1 (`width(j)` the width of quantile j, data units):
/// emit(j, p_j) with p_j = quantileMeanWeight / Σ of them, every j in order (mass 0 included).
/// The one normalisation of Eq. 5 for the distributions (1D and 2D).
template <class Width, class Emit>
void quantileMeanMasses(const QuantileLevels& levels, int q, bool densityWeights, double zeroWidth,
                        const Width& width, const Emit& emit) {
    bool pointMasses = false;
    for (int j = 0; densityWeights && j < q; ++j)
        pointMasses = pointMasses || width(j) <= zeroWidth;
    const auto weight = [&](int j) {
        return quantileMeanWeight<double>(levels.mass(j + 1), width(j), densityWeights, pointMasses,
                                          zeroWidth);
    };
    double total = 0.0;
    for (int j = 0; j < q; ++j) total += weight(j);
    for (int j = 0; j < q; ++j) emit(j, weight(j) / total);
}

/// A model's distribution at a cell (SPEC §3), model by model, as pieces into `sink`.
template <DistributionSink Sink>
struct DistributionAt {
    const Cell<double>& cell;
    Sink& sink;

    void operator()(const MeanKernel& k) const { sink.point(k.load<double>(cell, true), 1.0); }
    /// The box spline of the corners' intervals (SPEC §3 uniform; `uniform-fast` approximates
    /// the expectation over this same distribution).
    void operator()(const UniformKernel& k) const {
        const UniformSum u = k.sumAt(cell);
        if (u.n == 0)
            sink.point(u.shift, 1.0);
        else
            sink.boxSpline(u, 1.0);
    }
    void operator()(const GaussianKernel& k) const {
        double mu, sigma;
        k.paramsAt<double>(cell, true, mu, sigma);
        normalOrPoint(mu, sigma, 1.0);
    }
    void operator()(const GmmOrderedKernel& k) const {
        double pi[kMaxKernelGmmComponents], mu[kMaxKernelGmmComponents],
            sigma[kMaxKernelGmmComponents];
        k.componentsAt<double>(cell, true, pi, mu, sigma);  // π normalised (all 0: no mass)
        for (int i = 0; i < k.components; ++i)
            if (pi[i] != 0.0) normalOrPoint(mu[i], sigma[i], pi[i]);
    }
    /// Eq. 2 and 4: the rank population j0 … j1, each quantile uniform between its boundaries
    /// with its share of the population's mass (a point mass where its width is 0).
    void operator()(const QuantileRangeKernel& k) const {
        const double inv = k.levels.inverseTotal<double>(k.j1 - k.j0 + 1);
        double a = boundaryAt<double>(k.geometry, k.boundaries, k.stride, k.j0, cell, true);
        for (int j = k.j0 + 1; j <= k.j1; ++j) {
            const double b = boundaryAt<double>(k.geometry, k.boundaries, k.stride, j, cell, true);
            const double mass = k.levels.mass(j - k.j0) * inv;
            if (b > a)
                sink.uniform(a, b, mass);
            else
                sink.point(a, mass);
            a = b;
        }
    }
    /// Eq. 5: a point mass at each quantile's midpoint with quantileMeanWeight's share, every one
    /// of the q emitted (mass 0 included), in order.
    void operator()(const QuantileMeanKernel& k) const {
        const int stride = k.q + 1;
        const auto boundary = [&](int j) {
            return boundaryAt<double>(k.geometry, k.quantiles, stride, j, cell, true);
        };
        double a = boundary(0);  // quantile j's lower boundary: masses come in order
        quantileMeanMasses(
            k.levels, k.q, k.densityWeights, k.zeroWidth,
            [&](int j) { return widthAt<double>(k.geometry, k.quantiles, stride, j, cell, true); },
            [&](int j, double mass) {
                const double b = boundary(j + 1);
                sink.point(0.5 * (a + b), mass);
                a = b;
            });
    }
    /// The ensemble itself: a point mass 1/n at each member's interpolated value.
    void operator()(const MembersKernel& k) const {
        for (int i = 0; i < k.n; ++i) sink.point(k.memberAt<double>(i, cell, true), 1.0 / k.n);
    }

  private:
    void normalOrPoint(double mu, double sigma, double mass) const {
        if (sigma > 0.0)
            sink.normal(mu, sigma, mass);
        else
            sink.point(mu, mass);
    }
};

/// visitor(kernel) for a kernel, or for the kernel a variant of kernels holds.
template <class Kernel, class Visitor>
void visitKernel(const Kernel& kernel, const Visitor& visitor) {
    if constexpr (requires { kernel.index(); })
        std::visit(visitor, kernel);
    else
        visitor(kernel);
}

/// The distribution of `kernel` (any 1D model kernel, or an AnyKernel) at a cell into `sink`.
template <class Kernel, DistributionSink Sink>
void distributionAt(const Kernel& kernel, const Cell<double>& cell, Sink& sink) {
    visitKernel(kernel, DistributionAt<Sink>{cell, sink});
}

/// Σ mass × (E[α·r], E[α·g], E[α·b], E[α]) over the pieces of a distribution.
struct ExpectationSum {
    double sum[4] = {0.0, 0.0, 0.0, 0.0};

    void add(double mass, const double e[4]) {
        for (int ch = 0; ch < 4; ++ch) sum[ch] += mass * e[ch];
    }
};

/// Mean and variance of a distribution given as pieces.
struct DistributionMoments {
    double mass = 0.0, first = 0.0, second = 0.0;  // Σ mass, Σ mass·E[X], Σ mass·E[X²]

    void point(double x, double m) { add(m, x, x * x); }
    void uniform(double a, double b, double m) {
        add(m, 0.5 * (a + b), (a * a + a * b + b * b) / 3.0);
    }
    void normal(double mu, double sigma, double m) { add(m, mu, mu * mu + sigma * sigma); }
    void boxSpline(const UniformSum& u, double m) {
        const double mu = u.mean();
        add(m, mu, mu * mu + u.variance());
    }
    double mean() const { return mass > 0.0 ? first / mass : 0.0; }
    double stddev() const {
        if (!(mass > 0.0)) return 0.0;
        const double mu = mean();
        return std::sqrt(std::max(0.0, second / mass - mu * mu));
    }

  private:
    void add(double m, double e1, double e2) {
        mass += m;
        first += m * e1;
        second += m * e2;
    }
};

/// A piece of a distribution with its probability mass.
template <class Piece>
struct Weighted {
    Piece piece;
    double mass;
};

/// A distribution at a point as its pieces, in the order they came (a DistributionSink that
/// can replay itself into another).
struct PointDistribution {
    struct Atom {
        double x, mass;
    };
    struct Uniform {
        double a, b, mass;
    };
    struct Normal {
        double mu, sigma, mass;
    };
    using BoxSpline = Weighted<UniformSum>;
    std::vector<Atom> atoms;
    std::vector<Uniform> uniforms;
    std::vector<Normal> normals;
    std::vector<BoxSpline> boxSplines;

    void point(double x, double m) { atoms.push_back({x, m}); }
    void uniform(double a, double b, double m) { uniforms.push_back({a, b, m}); }
    void normal(double mu, double sigma, double m) { normals.push_back({mu, sigma, m}); }
    void boxSpline(const UniformSum& u, double m) { boxSplines.push_back({u, m}); }

    /// The pieces into another sink: atoms, uniforms, normals, box splines.
    template <DistributionSink Sink>
    void replay(Sink& s) const {
        for (const Atom& p : atoms) s.point(p.x, p.mass);
        for (const Uniform& p : uniforms) s.uniform(p.a, p.b, p.mass);
        for (const Normal& p : normals) s.normal(p.mu, p.sigma, p.mass);
        for (const BoxSpline& p : boxSplines) s.boxSpline(p.piece, p.mass);
    }
    /// Mass of the pieces that are not point masses.
    double continuousMass() const;
    /// [lo, hi] holding every piece: normals to μ ± sigmas·σ; {0, 0} when empty.
    std::pair<double, double> support(double sigmas) const;
    /// P(X ≤ x) of the continuous pieces at n + 1 points evenly over [lo, hi] (n ≥ 1).
    std::vector<double> continuousCdf(double lo, double hi, int n) const;
};
static_assert(DistributionSink<PointDistribution> && DistributionSink<DistributionMoments>);

/// E[TF(X)] of a 1D TF over any distribution (Eq. 3; SPEC §4), before opacity correction:
/// Σ over the pieces of mass × the piece's closed form (TF at a point, TF's mean over a uniform,
/// expectedTfGaussian, expectedTfUniformSum). The exact reference every 1D kernel's
/// classification is held to.
void expectedTfOver(const TfPieces<double>& tf, const PointDistribution& d, double out[4]);

}  // namespace udvr
