#pragma once
// A 2D-TF model's joint distribution of (X, G) at a point (SPEC §9: X the value, G the gradient
// magnitude along the mean gradient), apart from the expectation of a TF2 over it — the 2D
// counterpart of point_distribution.h (docs/architecture.md, "Distributions and
// expectations"). jointDistributionAt reconstructs a 2D kernel's random vector once, in
// double, as pieces of probability mass into a JointDistributionSink: points (the mean
// field, Eq. 5's midpoints), segments (the rank-coupled quantile population, Eq. 4), bivariate
// normals and bivariate box splines. Its consumers are the sinks:
//   - JointPointDistribution stores the pieces: expectedTf2Over, the expectation of a TF2 over
//     any joint distribution, which every 2D kernel's classification is held to
//     (joint_distribution_test.cpp);
//   - JointMoments: the means and covariance probe prints (probe.cpp).
// The kernels' lane bodies (model_kernels_2d.h) are the fast path of the same definitions.
#include <concepts>
#include <vector>

#include "udvr/classify/model_kernels_2d.h"
#include "udvr/classify/point_distribution.h"

namespace udvr {

/// The joint distribution of `kernel` (any 2D kernel, or an AnyKernel2D) at a cell into `sink`:
/// the kernel's reconstruction in double (model_kernels_2d.h), described as pieces
/// (distributions_2d.h).
template <class Kernel, JointDistributionSink Sink>
void jointDistributionAt(const Kernel& kernel, const Cell<double>& cell, Sink& sink) {
    visitKernel(kernel, [&](const auto& k) {
        k.template reconstruct<double>(cell, true, [&](const auto& d) { describe(d, sink); });
    });
}

/// Means and covariance of (X, G) over a joint distribution given as pieces. Each piece comes
/// with its own mean and central second moments and is merged by Chan et al.'s pairwise update,
/// so a narrow distribution far from 0 keeps its variance (no E[G²] − E[G]² cancellation).
struct JointMoments {
    double mass = 0.0;
    double mx = 0.0, mg = 0.0;               // means
    double cxx = 0.0, cxg = 0.0, cgg = 0.0;  // Σ of mass × central second moments

    void point(double x, double g, double m) { add(m, Normal2{x, g, 0.0, 0.0, 0.0}); }
    /// Uniform along the segment: var(u) = 1/12 for u ~ U[0, 1].
    void segment(double xa, double ga, double xb, double gb, double m) {
        const double dx = xb - xa, dg = gb - ga;
        add(m, Normal2{0.5 * (xa + xb), 0.5 * (ga + gb), dx * dx / 12.0, dx * dg / 12.0,
                       dg * dg / 12.0});
    }
    void normal(const Normal2& n, double m) { add(m, n); }
    /// var(t) = 1/3 for t ~ U[−1, 1].
    void boxSpline(const BoxSpline2& b, double m) {
        Normal2 n{b.cx, b.cg, 0.0, 0.0, 0.0};
        for (int i = 0; i < b.n; ++i) {
            n.vxx += b.d[i].a * b.d[i].a / 3.0;
            n.vxg += b.d[i].a * b.d[i].b / 3.0;
            n.vgg += b.d[i].b * b.d[i].b / 3.0;
        }
        add(m, n);
    }
    double varX() const { return mass > 0.0 ? cxx / mass : 0.0; }
    double covXG() const { return mass > 0.0 ? cxg / mass : 0.0; }
    double varG() const { return mass > 0.0 ? cgg / mass : 0.0; }

  private:
    /// Merges a piece of mass m with means and covariance `n` (only its moments are used).
    void add(double m, const Normal2& n) {
        if (!(m > 0.0)) return;
        const double total = mass + m, dx = n.mx - mx, dg = n.mg - mg, f = mass * m / total;
        cxx += m * n.vxx + f * dx * dx;
        cxg += m * n.vxg + f * dx * dg;
        cgg += m * n.vgg + f * dg * dg;
        mx += dx * m / total;
        mg += dg * m / total;
        mass = total;
    }
};

/// A joint distribution at a point as its pieces, in the order they came.
struct JointPointDistribution {
    struct Point {
        double x, g, mass;
    };
    struct Segment {
        double xa, ga, xb, gb, mass;
    };
    std::vector<Point> points;
    std::vector<Segment> segments;
    std::vector<Weighted<Normal2>> normals;
    std::vector<Weighted<BoxSpline2>> boxSplines;

    void point(double x, double g, double m) { points.push_back({x, g, m}); }
    void segment(double xa, double ga, double xb, double gb, double m) {
        segments.push_back({xa, ga, xb, gb, m});
    }
    void normal(const Normal2& n, double m) { normals.push_back({n, m}); }
    void boxSpline(const BoxSpline2& b, double m) { boxSplines.push_back({b, m}); }
};
static_assert(JointDistributionSink<JointPointDistribution> && JointDistributionSink<JointMoments>);

/// E[TF2(X, G)] over any joint distribution (SPEC §9), before opacity correction: Σ over the
/// pieces of mass × the piece's expectation (TF2 at a point, its mean along a segment,
/// expectedTf2Gaussian, expectedTf2UniformExact). The exact reference every 2D kernel's
/// classification is held to.
void expectedTf2Over(const Tf2Raster<double>& tf, const JointPointDistribution& d, double out[4]);

}  // namespace udvr
