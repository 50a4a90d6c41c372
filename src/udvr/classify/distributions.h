#pragma once
// The models' random variables at a point (SPEC §3) as values over T ∈ {double, float,
// lanes::Vf} (docs/architecture.md, "Distributions and expectations"). A 1D kernel's
// `reconstruct` (model_kernels.h) builds its model's distribution once per sample and hands it
// on; what is done with it is written once per distribution kind, whichever model made it:
//   - expectedTf(tf, d, live, out): E[TF(X)] of a 1D TF over it (Eq. 3), on any T — the render
//     path (lanes), the exact double body and a GPU thread's float;
//   - describe(d, sink): its pieces of probability mass into a DistributionSink, in double —
//     probe's JSON and plot, expectedTfOver (the reference every kernel is held to) and the
//     bivariate TF2's per-cell moments (expected_tf2_bivariate.h);
//   - laneAsDouble(d, l): lane l of a distribution over T as the double one, for what is written
//     only in double (the bivariate TF2's moments: its lanes describe() each lane's).
// The value × gradient counterpart (a joint distribution into a JointDistributionSink) is
// classify/joint_distribution.h.
#include <algorithm>
#include <concepts>
#include <type_traits>

#include "udvr/classify/expected_tf.h"
#include "udvr/reconstruct/box_spline.h"
#include "udvr/reconstruct/quantile_interp.h"

namespace udvr {

/// Largest GMM K the kernels handle (stack arrays).
inline constexpr int kMaxKernelGmmComponents = 16;

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

namespace detail {
/// A normal piece N(μ, σ²) with `mass` into a distribution sink, a point mass where σ = 0.
template <class Sink>
void normalOrPoint(Sink& sink, double mu, double sigma, double mass) {
    if (sigma > 0.0)
        sink.normal(mu, sigma, mass);
    else
        sink.point(mu, mass);
}
/// f(view): on AVX2 (lanes::kWindowLookups) the 8-piece window of `tf` that holds the pieces of
/// every live lane's values in [lo, hi], where one does (lookups: one permute instead of two or
/// four and blends; in a batch of neighbouring rays the quantiles of a sample seldom span more
/// than 8 pieces) where `worth` (choosing costs two reductions and two piece searches: iqr's
/// single interval does not repay them); otherwise `tf` itself. The callee may only look up
/// values in [lo, hi].
template <class Tf, class F>
UDVR_INLINE void withPieceWindow(const Tf& tf, lanes::Vf lo, lanes::Vf hi, lanes::Mask live,
                                 bool worth, const F& f) {
    if constexpr (lanes::kWindowLookups && Tf::kLookupSize != 8) {
        if (worth && lanes::anyOf(live)) {
            // pieceOf is monotone: the pieces of the extreme values bound every lane's.
            const int first = tf.pieceOf(lanes::minOf(lo, live));
            const int last = tf.pieceOf(lanes::maxOf(hi, live));
            if (last - first < 8 && first + 8 <= tf.stride) {
                f(tf.window(first, last - first));
                return;
            }
        }
    }
    f(tf);
}
/// f(view) for the values boundary(0) ≤ … ≤ boundary(last) of a sorted run: the piece window
/// on lanes where `windowed` (the batch's transposed rows: the ends cost nothing), else `tf`.
template <class T, class Tf, class Boundary, class F>
UDVR_CPU_GPU UDVR_INLINE void withSortedRun(const Tf& tf, bool windowed, const Boundary& boundary,
                                            int last, lanes::MaskOf<T> live, bool worth,
                                            const F& f) {
    if constexpr (lanes::kIsVector<T>) {
        if (windowed) {
            withPieceWindow(tf, boundary(0), boundary(last), live, worth, f);
            return;
        }
    } else {
        (void)windowed, (void)boundary, (void)last, (void)live, (void)worth;
    }
    f(tf);
}
/// Lane l of a value over T as a double (float and double: the value; l is ignored).
template <class T>
UDVR_CPU_GPU UDVR_INLINE double laneValue(const T& v, int l) {
    if constexpr (lanes::kIsVector<T>) {
        return v[l];
    } else {
        (void)l;
        return static_cast<double>(v);
    }
}
/// The callable j ↦ lane l of f(j) as a double (a lane distribution's boundaries, widths).
template <class F>
UDVR_CPU_GPU UDVR_INLINE auto laneOf(const F& f, int l) {
    return [f, l](int j) UDVR_INLINE_LAMBDA { return laneValue(f(j), l); };
}
/// A DistributionSink that keeps nothing: the archetype the concept below is checked with.
struct AnySink {
    void point(double, double) {}
    void uniform(double, double, double) {}
    void normal(double, double, double) {}
    void boxSpline(const UniformSum&, double) {}
};
}  // namespace detail

/// A point mass at x (the mean field, SPEC §3 `mean`).
template <class T>
struct PointMass {
    using Real = T;
    T x;
};
template <DistributionSink Sink>
void describe(const PointMass<double>& d, Sink& sink) {
    sink.point(d.x, 1.0);
}
template <class T>
UDVR_INLINE PointMass<double> laneAsDouble(const PointMass<T>& d, int l) {
    return {detail::laneValue(d.x, l)};
}
template <class T, class Tf>
UDVR_CPU_GPU UDVR_INLINE void expectedTf(const Tf& tf, const PointMass<T>& d, lanes::MaskOf<T>,
                                         T out[4]) {
    tfAt<T>(tf, d.x, out);
}

/// N(μ, σ²) (`gaussian`); σ = 0 is the point mass at μ.
template <class T>
struct NormalDistribution {
    using Real = T;
    T mu, sigma;
};
template <DistributionSink Sink>
void describe(const NormalDistribution<double>& d, Sink& sink) {
    detail::normalOrPoint(sink, d.mu, d.sigma, 1.0);
}
template <class T>
UDVR_INLINE NormalDistribution<double> laneAsDouble(const NormalDistribution<T>& d, int l) {
    return {detail::laneValue(d.mu, l), detail::laneValue(d.sigma, l)};
}
template <class T, class Tf>
UDVR_CPU_GPU UDVR_INLINE void expectedTf(const Tf& tf, const NormalDistribution<T>& d,
                                         lanes::MaskOf<T> live, T out[4]) {
    expectedTfGaussian<T>(tf, d.mu, d.sigma, live, out);
}
/// Lanes whose float closed form would lose (σ/w)² × its rounding (kMaxFloatSigmaOverPiece of the
/// TF's narrowest piece w): they need the double body.
template <class T>
UDVR_CPU_GPU UDVR_INLINE lanes::MaskOf<T> tooWideForFloat(const NormalDistribution<T>& d,
                                                          float narrowestPiece) {
    return d.sigma > kMaxFloatSigmaOverPiece * narrowestPiece;
}

/// The mixture Σ_k π_k N(μ_k, σ_k²), Σπ = 1 (`gmm-ordered`); all π = 0: no mass.
template <class T>
struct NormalMixture {
    using Real = T;
    int k = 0;
    T pi[kMaxKernelGmmComponents], mu[kMaxKernelGmmComponents], sigma[kMaxKernelGmmComponents];
};
template <DistributionSink Sink>
void describe(const NormalMixture<double>& d, Sink& sink) {
    for (int i = 0; i < d.k; ++i)
        if (d.pi[i] != 0.0) detail::normalOrPoint(sink, d.mu[i], d.sigma[i], d.pi[i]);
}
template <class T>
UDVR_INLINE NormalMixture<double> laneAsDouble(const NormalMixture<T>& d, int l) {
    NormalMixture<double> r;
    r.k = d.k;
    for (int i = 0; i < d.k; ++i) {
        r.pi[i] = detail::laneValue(d.pi[i], l);
        r.mu[i] = detail::laneValue(d.mu[i], l);
        r.sigma[i] = detail::laneValue(d.sigma[i], l);
    }
    return r;
}
/// Σ_k π_k·E[TF(N(μ_k, σ_k²))] in the `live` lanes (0 elsewhere).
template <class T, class Tf>
UDVR_CPU_GPU UDVR_INLINE void expectedTf(const Tf& tf, const NormalMixture<T>& d,
                                         lanes::MaskOf<T> live, T out[4]) {
    for (int ch = 0; ch < 4; ++ch) out[ch] = T{};
    for (int i = 0; i < d.k; ++i) {
        const auto use = live & (d.pi[i] != 0);
        if (!lanes::anyOf(use)) continue;
        T e[4];
        expectedTfGaussian<T>(tf, d.mu[i], d.sigma[i], use, e);
        for (int ch = 0; ch < 4; ++ch)
            out[ch] = lanes::select(use, lanes::fma(d.pi[i], e[ch], out[ch]), out[ch]);
    }
}
template <class T>
UDVR_CPU_GPU UDVR_INLINE lanes::MaskOf<T> tooWideForFloat(const NormalMixture<T>& d,
                                                          float narrowestPiece) {
    auto wide = lanes::MaskOf<T>{};
    for (int i = 0; i < d.k; ++i)
        wide = wide | (d.sigma[i] > kMaxFloatSigmaOverPiece * narrowestPiece);
    return wide;
}

/// The box spline X = Σ_c w_c U[lo_c, hi_c] of a cell's 8 corners (`uniform`, SPEC §3), with
/// its two evaluations' resolutions (data units): widths ≤ tinyWidth fold into the shift of the
/// exact sum (sum()), and sums narrower than pointWidth are point masses of the fast form
/// (fast()).
template <class T>
struct CornerBoxSpline {
    using Real = T;
    T w[8], lo[8], hi[8];
    double tinyWidth = 0.0, pointWidth = 0.0;
    bool exact = true;  // `uniform`: expectations by sum(); `uniform-fast`: by fast()

    /// The exact sum of scaled uniforms (double).
    UDVR_CPU_GPU UniformSum sum() const { return makeUniformSum(lo, hi, w, tinyWidth); }
    /// The fast form: the two widest boxes exact, the rest a Gaussian with κ4, κ6 terms.
    UDVR_CPU_GPU UDVR_INLINE BoxSplineFast<T> fast() const {
        return makeBoxSplineFast<T>(lo, hi, w, static_cast<lanes::ScalarOf<T>>(pointWidth));
    }
};
template <DistributionSink Sink>
void describe(const CornerBoxSpline<double>& d, Sink& sink) {
    const UniformSum u = d.sum();
    if (u.n == 0)
        sink.point(u.shift, 1.0);
    else
        sink.boxSpline(u, 1.0);
}
template <class T>
UDVR_INLINE CornerBoxSpline<double> laneAsDouble(const CornerBoxSpline<T>& d, int l) {
    CornerBoxSpline<double> r;
    for (int c = 0; c < 8; ++c) {
        r.w[c] = detail::laneValue(d.w[c], l);
        r.lo[c] = detail::laneValue(d.lo[c], l);
        r.hi[c] = detail::laneValue(d.hi[c], l);
    }
    r.tinyWidth = d.tinyWidth;
    r.pointWidth = d.pointWidth;
    r.exact = d.exact;
    return r;
}
/// E[TF(X)]: exact (double only; SPEC §4's 1e−4) or by the fast form (expectedTfUniformFast,
/// within 4e−4 of it; docs/models.md).
template <class T, class Tf>
UDVR_CPU_GPU UDVR_INLINE void expectedTf(const Tf& tf, const CornerBoxSpline<T>& d,
                                         lanes::MaskOf<T> live, T out[4]) {
    if constexpr (std::is_same_v<T, double>) {
        if (d.exact) {
            expectedTfUniformSum(tf, d.sum(), out);
            return;
        }
    }
    expectedTfUniformFast<T>(tf, d.fast(), static_cast<lanes::ScalarOf<T>>(d.pointWidth), live,
                             out);
}

/// The quantile population between boundaries boundary(0) ≤ … ≤ boundary(count − 1) (Eq. 2):
/// quantile j uniform over [b_{j−1}, b_j] with mass levels.mass(j) of the population's total.
/// `boundary(j)` gives boundary j at the sample (a batch's transposed rows where `windowed`).
template <class T, class Boundary>
struct QuantilePopulation {
    using Real = T;
    Boundary boundary;
    int count;
    QuantileLevels levels;
    bool windowed = false;
};
template <class Boundary, DistributionSink Sink>
void describe(const QuantilePopulation<double, Boundary>& d, Sink& sink) {
    const double inv = d.levels.template inverseTotal<double>(d.count);
    double a = d.boundary(0);
    for (int j = 1; j < d.count; ++j) {
        const double b = d.boundary(j);
        const double mass = d.levels.mass(j) * inv;
        if (b > a)
            sink.uniform(a, b, mass);
        else
            sink.point(a, mass);
        a = b;
    }
}
template <class T, class Boundary>
UDVR_INLINE auto laneAsDouble(const QuantilePopulation<T, Boundary>& d, int l) {
    const auto boundary = detail::laneOf(d.boundary, l);
    return QuantilePopulation<double, decltype(boundary)>{boundary, d.count, d.levels};
}
/// Eq. 4: Σ_j mass_j × (mean of TF over quantile j) / Σ mass.
template <class T, class Tf, class Boundary>
UDVR_CPU_GPU UDVR_INLINE void expectedTf(const Tf& tf, const QuantilePopulation<T, Boundary>& d,
                                         lanes::MaskOf<T> live, T out[4]) {
    detail::withSortedRun<T>(tf, d.windowed, d.boundary, d.count - 1, live, d.count > 2,
                             [&](const auto& t) UDVR_INLINE_LAMBDA {
                                 expectedTfQuantileRange<T>(t, d.boundary, d.count, d.levels, out);
                             });
}

/// Eq. 5's point masses: quantile j's midpoint between boundary(j) and boundary(j + 1), j < q,
/// weighted by forEachQuantileMeanWeight (density weights p_j ∝ mass_j / width(j), or the masses);
/// widths ≤ zeroWidth (data units) are point masses of infinite density.
template <class T, class Boundary, class Width>
struct QuantileMidpoints {
    using Real = T;
    Boundary boundary;
    Width width;
    int q;
    QuantileLevels levels;
    bool densityWeights;
    double zeroWidth;
    bool windowed = false;
};
template <class Boundary, class Width, DistributionSink Sink>
void describe(const QuantileMidpoints<double, Boundary, Width>& d, Sink& sink) {
    double a = d.boundary(0);  // quantile j's lower boundary: masses come in order
    quantileMeanMasses(d.levels, d.q, d.densityWeights, d.zeroWidth, d.width,
                       [&](int j, double mass) UDVR_INLINE_LAMBDA {
                           const double b = d.boundary(j + 1);
                           sink.point(0.5 * (a + b), mass);
                           a = b;
                       });
}
template <class T, class Boundary, class Width>
UDVR_INLINE auto laneAsDouble(const QuantileMidpoints<T, Boundary, Width>& d, int l) {
    const auto boundary = detail::laneOf(d.boundary, l);
    const auto width = detail::laneOf(d.width, l);
    return QuantileMidpoints<double, decltype(boundary), decltype(width)>{
        boundary, width, d.q, d.levels, d.densityWeights, d.zeroWidth};
}
template <class T, class Tf, class Boundary, class Width>
UDVR_CPU_GPU UDVR_INLINE void expectedTf(const Tf& tf,
                                         const QuantileMidpoints<T, Boundary, Width>& d,
                                         lanes::MaskOf<T> live, T out[4]) {
    const T zero = lanes::splat<T>(static_cast<lanes::ScalarOf<T>>(d.zeroWidth));
    detail::withSortedRun<T>(tf, d.windowed, d.boundary, d.q, live, d.q > 1,
                             [&](const auto& t) UDVR_INLINE_LAMBDA {
                                 expectedTfQuantileMean<T>(t, d.boundary, d.width, d.q, d.levels,
                                                           d.densityWeights, zero, live, out);
                             });
}

/// n equally likely values (`members`: the ensemble at a point). `values(first, count, f)`
/// writes values first … first + count − 1 into f (count ≤ kMaxRowBoundaries).
template <class T, class Values>
struct EqualMasses {
    using Real = T;
    Values values;
    int n;
};
template <class Values, DistributionSink Sink>
void describe(const EqualMasses<double, Values>& d, Sink& sink) {
    double x[kMaxRowBoundaries];
    for (int first = 0; first < d.n; first += kMaxRowBoundaries) {
        const int count = std::min(d.n - first, kMaxRowBoundaries);
        d.values(first, count, x);
        for (int i = 0; i < count; ++i) sink.point(x[i], 1.0 / d.n);
    }
}
/// Lane l's values: a block of the batch's values (one transposed block of rows on lanes) at a
/// time, as describe() reads them.
template <class T, class Values>
UDVR_INLINE auto laneAsDouble(const EqualMasses<T, Values>& d, int l) {
    const auto values = [all = d.values, l](int first, int count, double* f) UDVR_INLINE_LAMBDA {
        T v[kMaxRowBoundaries];
        all(first, count, v);
        for (int i = 0; i < count; ++i) f[i] = detail::laneValue(v[i], l);
    };
    return EqualMasses<double, decltype(values)>{values, d.n};
}
/// (1/n) Σ_i TF(f_i), blocks of kMaxRowBoundaries values at a time.
template <class T, class Tf, class Values>
UDVR_CPU_GPU UDVR_INLINE void expectedTf(const Tf& tf, const EqualMasses<T, Values>& d,
                                         lanes::MaskOf<T>, T out[4]) {
    for (int ch = 0; ch < 4; ++ch) out[ch] = T{};
    T f[kMaxRowBoundaries];
    for (int first = 0; first < d.n; first += kMaxRowBoundaries) {
        const int count = d.n - first < kMaxRowBoundaries ? d.n - first : kMaxRowBoundaries;
        d.values(first, count, f);
        for (int i = 0; i < count; ++i) {
            T e[4];
            tfAt<T>(tf, f[i], e);
            for (int ch = 0; ch < 4; ++ch) out[ch] += e[ch];
        }
    }
    const T inv = lanes::splat<T>(static_cast<lanes::ScalarOf<T>>(1.0 / d.n));
    for (int ch = 0; ch < 4; ++ch) out[ch] *= inv;
}

/// Whether a distribution kind has lanes its float closed form cannot serve (tooWideForFloat).
template <class D>
inline constexpr bool hasFloatLimit = requires(const D& d) {
    tooWideForFloat(d, 1.f);
};

/// What the distribution kinds of every TF kind share (Distribution1D, distributions_2d.h's
/// Distribution2D): over double, D also describes itself as pieces into a `Sink` (probe's
/// description, the reference expectations); over float and lanes it need not.
template <class D, class Sink>
concept DescribedInDouble =
    !std::is_same_v<typename D::Real, double> || requires(const D& d, Sink& sink) {
    describe(d, sink);
};

/// The contract of a model's distribution at a point (what a kernel's `reconstruct` hands on),
/// over its real type D::Real: a 1D TF's expectation over it on that type, and over double also
/// its description as pieces of probability mass.
template <class D>
concept Distribution1D = requires(const D& d, const detail::TfFor<typename D::Real>& tf,
                                  lanes::MaskOf<typename D::Real> live, typename D::Real* out) {
    expectedTf(tf, d, live, out);
}
&&DescribedInDouble<D, detail::AnySink>;

}  // namespace udvr
