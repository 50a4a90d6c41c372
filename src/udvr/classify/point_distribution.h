#pragma once
// A model's distribution at a point (SPEC §3) as pieces of probability mass, apart from the
// expectation of any TF over it (docs/architecture.md, "Distributions and expectations"). Each
// 1D kernel's `reconstruct` (model_kernels.h) builds its model's random variable once, as a
// Distribution1D over the lane type (distributions.h); distributionAt describes the double one
// into a DistributionSink: point masses, uniform pieces (Eq. 2's quantiles), normals and box
// splines.
// Its consumers are the sinks:
//   - PointDistribution stores the pieces: probe's JSON and plot (probe.cpp) and expectedTfOver,
//     the expectation of a 1D TF over any distribution (Eq. 3);
//   - AxisMoments (expected_tf2_bivariate.h): per-raster-cell moments, for a bivariate TF2;
//   - DistributionMoments: mean and variance.
// The render kernels' lane bodies take expectedTf over the same object (distributions.h);
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

/// visitor(kernel) for a kernel, or for the kernel a variant of kernels holds.
template <class Kernel, class Visitor>
void visitKernel(const Kernel& kernel, const Visitor& visitor) {
    if constexpr (requires { kernel.index(); })
        std::visit(visitor, kernel);
    else
        visitor(kernel);
}

/// The distribution of `kernel` (any 1D model kernel, or an AnyKernel) at a cell into `sink`:
/// the kernel's own reconstruction (model_kernels.h), described as pieces (distributions.h).
template <class Kernel, DistributionSink Sink>
void distributionAt(const Kernel& kernel, const Cell<double>& cell, Sink& sink) {
    visitKernel(kernel, [&](const auto& k) {
        k.template reconstruct<double>(cell, true, [&](const auto& d) { describe(d, sink); });
    });
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
