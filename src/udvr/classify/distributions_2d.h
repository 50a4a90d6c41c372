#pragma once
// A 2D-TF model's joint distribution of (X, G) at a point (SPEC §9: X the value, G the gradient
// magnitude along the mean gradient) as a value over the lane type T (double, float or
// lanes::Vf) — the 2D counterpart of distributions.h (docs/architecture.md, "Distributions and
// expectations"). A 2D kernel's `reconstruct<T>(cell, live, use)` builds it once and hands it to
// `use`; each kind comes with
//   - expectedTf2(tf, d, live, out): E[TF2(X, G)] over it (SPEC §9, before opacity correction),
//     on any T — the render's classification;
//   - describe(d, sink): its pieces of probability mass into a JointDistributionSink, in double
//     — probe's description and expectedTf2Over (joint_distribution.h), the reference the
//     render's classification is held to.
// So the polyline of the quantile models is built by one function and Eq. 4 / Eq. 5 in 2D are
// each taken by one. The 2D gaussian's is JointNormal, the 2D uniform's JointBoxSpline: both
// built over lanes too.
#include <bit>
#include <concepts>

#include "udvr/classify/distributions.h"
#include "udvr/classify/expected_tf.h"
#include "udvr/classify/expected_tf2.h"
#include "udvr/classify/expected_tf2_fast.h"
#include "udvr/classify/expected_tf2_gaussian.h"
#include "udvr/classify/expected_tf2_uniform_exact.h"
#include "udvr/classify/tf2_raster.h"
#include "udvr/reconstruct/quantile_interp.h"
#include "udvr/util/check.h"
#include "udvr/util/fast_math.h"

namespace udvr {

/// What receives a joint distribution of (X, G) (data units; masses sum to 1 over the pieces of
/// one point): point(x, g, m): mass m at (x, g); segment(xa, ga, xb, gb, m): m spread evenly
/// along the segment from (xa, ga) to (xb, gb); normal(n, m): m × a bivariate normal;
/// boxSpline(b, m): m × a bivariate box spline.
template <class S>
concept JointDistributionSink = requires(S& s, double v, const Normal2& n, const BoxSpline2& b) {
    s.point(v, v, v);
    s.segment(v, v, v, v, v);
    s.normal(n, v);
    s.boxSpline(b, v);
};

namespace detail {
/// A JointDistributionSink that keeps nothing: the archetype Distribution2D is checked with.
struct AnyJointSink {
    void point(double, double, double) {}
    void segment(double, double, double, double, double) {}
    void normal(const Normal2&, double) {}
    void boxSpline(const BoxSpline2&, double) {}
};
}  // namespace detail

/// A point mass at (x, g) (the mean field and the ground truth, SPEC §9 `mean`).
template <class T>
struct JointPoint {
    using Real = T;
    T x;  // the TF2's x: the value (or field 1), data units
    T g;  // the TF2's y: the gradient magnitude (or field 2)
};
template <JointDistributionSink Sink>
void describe(const JointPoint<double>& d, Sink& sink) {
    sink.point(d.x, d.g, 1.0);
}
template <class T, class Real>
UDVR_CPU_GPU UDVR_INLINE void expectedTf2(const Tf2Raster<Real>& tf, const JointPoint<T>& d,
                                          lanes::MaskOf<T> live, T out[4]) {
    tf2At<T>(tf, d.x, d.g, live, out);
}

/// The rank-coupled quantile population in 2D (Eq. 4, SPEC §9): the polyline through the
/// boundaries' (X_j, G_j), j < count, quantile j spread evenly along segment (j − 1, j) with mass
/// levels.mass(j) of the population's total. x and g: the caller's arrays (alive while d is).
template <class T>
struct QuantilePolyline {
    using Real = T;
    const T* x;
    const T* g;
    int count;
    QuantileLevels levels;
};
template <JointDistributionSink Sink>
void describe(const QuantilePolyline<double>& d, Sink& sink) {
    const double inv = d.levels.inverseTotal<double>(d.count);
    for (int j = 1; j < d.count; ++j)
        sink.segment(d.x[j - 1], d.g[j - 1], d.x[j], d.g[j], d.levels.mass(j) * inv);
}
/// Eq. 4: Σ_j mass_j × (mean of the TF2 along segment j) / Σ mass (expectedTf2QuantileRange:
/// the exact walk of the raster's cells).
template <class T, class Real>
UDVR_CPU_GPU UDVR_INLINE void expectedTf2(const Tf2Raster<Real>& tf, const QuantilePolyline<T>& d,
                                          lanes::MaskOf<T> live, T out[4]) {
    expectedTf2QuantileRange<T>(tf, d.x, d.g, d.count, d.levels, live, out);
}

/// Eq. 5 in 2D: quantile j's point mass at the midpoint of the segment (j, j + 1) of the
/// quantiles' polyline (its vertices and levels), j < count − 1, weighted by
/// forEachQuantileMeanWeight (density weights p_j ∝ mass_j / width(j), or the masses); widths ≤
/// zeroWidth (data units) are point masses of infinite density.
template <class T, class Width>
struct PolylineMidpoints {
    using Real = T;
    QuantilePolyline<T> polyline;
    Width width;
    bool densityWeights;
    double zeroWidth;
};
template <class Width, JointDistributionSink Sink>
void describe(const PolylineMidpoints<double, Width>& d, Sink& sink) {
    const QuantilePolyline<double>& p = d.polyline;
    quantileMeanMasses(
        p.levels, p.count - 1, d.densityWeights, d.zeroWidth, d.width, [&](int j, double mass) {
            sink.point(0.5 * (p.x[j] + p.x[j + 1]), 0.5 * (p.g[j] + p.g[j + 1]), mass);
        });
}
template <class T, class Real, class Width>
UDVR_CPU_GPU UDVR_INLINE void expectedTf2(const Tf2Raster<Real>& tf,
                                          const PolylineMidpoints<T, Width>& d,
                                          lanes::MaskOf<T> live, T out[4]) {
    using S = lanes::ScalarOf<T>;
    const QuantilePolyline<T>& p = d.polyline;
    quantileMeanWeighted<T>(
        [&](int j, T v[4]) UDVR_INLINE_LAMBDA {
            tf2At<T>(tf, (p.x[j] + p.x[j + 1]) * S(0.5), (p.g[j] + p.g[j + 1]) * S(0.5), live, v);
        },
        d.width, p.count - 1, p.levels, d.densityWeights,
        lanes::splat<T>(static_cast<S>(d.zeroWidth)), live, out);
}

/// The 2D gaussian's (X, G) (SPEC §9): the bivariate normal N((mx, mg), [[vxx, vxg], [vxg, vgg]])
/// of the 32-voxel form, a point where neither has variance. Its E[TF2] is taken over the TF2 in
/// double, `exact`: by the prefiltered tables where `tables` (`gaussian`, Tf2BlurTables::gaussian:
/// over lanes the table sums in float) or else exactly (`gaussian-exact`, expectedTf2Gaussian, per
/// lane in double) — so the raster of T's real type that expectedTf2 is handed is not read.
template <class T>
struct JointNormal {
    using Real = T;
    T mx, mg, vxx, vxg, vgg;
    const Tf2Raster<double>* exact;
    const Tf2BlurTables* tables;  // null: exactly
};
template <JointDistributionSink Sink>
void describe(const JointNormal<double>& d, Sink& sink) {
    if (d.vxx > 0.0 || d.vgg > 0.0)
        sink.normal(Normal2{d.mx, d.mg, d.vxx, d.vxg, d.vgg}, 1.0);
    else
        sink.point(d.mx, d.mg, 1.0);
}
template <class T, class Real>
UDVR_INLINE void expectedTf2(const Tf2Raster<Real>&, const JointNormal<T>& d, lanes::MaskOf<T> live,
                             T out[4]) {
    if constexpr (lanes::kIsVector<T>) {
        if (d.tables) {
            const lanes::Vf m[5] = {d.mx, d.mg, d.vxx, d.vxg, d.vgg};
            d.tables->gaussian(*d.exact, m, live, out);
            return;
        }
        for (std::uint32_t b = lanes::bits(live); b; b &= b - 1) {
            const int l = std::countr_zero(b);
            double v[4];
            expectedTf2Gaussian(*d.exact, d.mx[l], d.mg[l], d.vxx[l], d.vxg[l], d.vgg[l], v);
            for (int ch = 0; ch < 4; ++ch) out[ch][l] = static_cast<float>(v[ch]);
        }
    } else {
        if (!live) return;
        double v[4];
        if (d.tables)
            d.tables->gaussian(*d.exact, d.mx, d.mg, d.vxx, d.vxg, d.vgg, v);
        else
            expectedTf2Gaussian(*d.exact, d.mx, d.mg, d.vxx, d.vxg, d.vgg, v);
        for (int ch = 0; ch < 4; ++ch) out[ch] = static_cast<T>(v[ch]);
    }
}

/// The 2D uniform's (X, G) (SPEC §9): the bivariate box spline (cx, cg) + Σ_i t_i·(a_i, b_i),
/// t_i ~ U[−1, 1] independent, of the 32-voxel form (direction i: voxel i's trilinear weight w_i
/// and gradient coefficient u_i = n̂·g_i times its half width h_i; data units). Its values are
/// doubles on every T (Wide: kWidth doubles on lanes), the inputs of the double evaluation of
/// its E[TF2]: float sums would move the centre's G, a sum of ~32 terms u_i·mid_i that cancel
/// to |μ_Y|, by float roundings of the values (docs/models.md). E[TF2] per lane in double:
/// `tables` (the fast `uniform`, Tf2BlurTables::boxSpline) where the sample's 8 corners have
/// weight (allCorners), else expectedTf2UniformExact, converged (`converged`: uniform-exact) or at
/// the coarse kUniform2DFast settings refined where they miss (expectedTf2UniformRefined).
/// Directions with |a| ≤ tinyWidth count for G only.
template <class T>
struct JointBoxSpline {
    using Real = T;
    using Wide = std::conditional_t<lanes::kIsVector<T>, lanes::Vec<double, lanes::kWidth>, double>;
    Wide cx{}, cg{};
    Wide a[32], b[32];
    lanes::IntOf<T> count{};        // directions per lane (≤ 32)
    lanes::MaskOf<T> allCorners{};  // lanes whose 8 corners have trilinear weight > 0
    double tinyWidth = 0.0;
    const Tf2Raster<double>* raster = nullptr;
    const Tf2BlurTables* tables = nullptr;  // null: expectedTf2UniformExact
    bool converged = false;                 // uniform-exact: its default (converged) settings
};
namespace detail {
/// E[(α·c, α)] over one lane's box spline (JointBoxSpline) in double.
template <class T>
void boxSplineExpectation(const JointBoxSpline<T>& s, double cx, double cg, const BoxDirection2* d,
                          int n, bool allCorners, double out[4]) {
    if (s.tables && !s.converged && allCorners) {
        s.tables->boxSpline(*s.raster, cx, cg, d, n, s.tinyWidth, out);
    } else if (s.converged) {
        Tf2UniformExactOptions opt;
        expectedTf2UniformExact(*s.raster, cx, cg, d, n, s.tinyWidth, opt, out);
    } else {
        expectedTf2UniformRefined(*s.raster, cx, cg, d, n, s.tinyWidth, out);
    }
}
}  // namespace detail
template <JointDistributionSink Sink>
void describe(const JointBoxSpline<double>& s, Sink& sink) {
    BoxSpline2 b;
    b.cx = s.cx;
    b.cg = s.cg;
    b.n = s.count;
    for (int i = 0; i < s.count; ++i) b.d[i] = {s.a[i], s.b[i]};
    b.tinyWidth = s.tinyWidth;
    sink.boxSpline(b, 1.0);
}
/// E[TF2] over the box spline, per live lane in double (the raster of T's real type is not read).
template <class T, class Real>
void expectedTf2(const Tf2Raster<Real>&, const JointBoxSpline<T>& s, lanes::MaskOf<T> live,
                 T out[4]) {
    BoxDirection2 d[32];
    double v[4];
    if constexpr (lanes::kIsVector<T>) {
        for (std::uint32_t m = lanes::bits(live); m; m &= m - 1) {
            const int l = std::countr_zero(m);
            const int n = s.count[l];
            for (int i = 0; i < n; ++i) d[i] = {s.a[i][l], s.b[i][l]};
            detail::boxSplineExpectation(s, s.cx[l], s.cg[l], d, n, s.allCorners[l] != 0, v);
            for (int ch = 0; ch < 4; ++ch) out[ch][l] = static_cast<float>(v[ch]);
        }
    } else {
        if (!live) return;
        for (int i = 0; i < s.count; ++i) d[i] = {s.a[i], s.b[i]};
        detail::boxSplineExpectation(s, s.cx, s.cg, d, s.count, s.allCorners, v);
        for (int ch = 0; ch < 4; ++ch) out[ch] = static_cast<T>(v[ch]);
    }
}

/// The contract of a 2D model's joint distribution at a point (what a 2D kernel's
/// `reconstruct` hands on), over its real type D::Real: a TF2's expectation over it on that
/// type, and over double also its description as pieces of probability mass.
template <class D>
concept Distribution2D = requires(const D& d,
                                  const Tf2Raster<lanes::ScalarOf<typename D::Real>>& tf,
                                  lanes::MaskOf<typename D::Real> live, typename D::Real* out) {
    expectedTf2(tf, d, live, out);
}
&&DescribedInDouble<D, detail::AnyJointSink>;

}  // namespace udvr
