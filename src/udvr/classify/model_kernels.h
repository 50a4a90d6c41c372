#pragma once
// The kernel of each model family (SPEC §3–4): reconstruction at a cell (reconstruct/) and the
// expected TF (expected_tf.h), each written once over T ∈ {double, float, lanes::Vf}: double is
// the exact path (probe, references, lanes too wide for float), lanes::Vf the CPU batch of 16
// samples, float one GPU thread.
//
// Every kernel K provides
//   template <class T> using Loaded = …;
//   template <class T> Loaded<T> load(const Cell<T>& cell, MaskOf<T> live) const;
//       reads the corners of the live lanes' cells and reconstructs (for the costly models it
//       classifies too);
//   template <class T> void finish(const Loaded<T>&, T out[4]) const;
//       (E[α·r], E[α·g], E[α·b], E[α]) before opacity correction; 0 in lanes that were not
//       live, except for kernels with kLoadDeadLanes (the mean: dead lanes hold TF of whatever
//       was loaded, and the ray loop's compositor masks them);
//   void voxelSupport(std::size_t voxel, float& lo, float& hi) const;
//       a value interval outside which the voxel's distribution has no (or negligible) mass, for
//       the empty-space tables. The distribution at a point of a cell lies inside the hull of its
//       corners' supports (supports interpolate linearly: Σ w(μ ± kσ) ⊇ μ(p) ± kσ(p) since
//       sqrt(Σw²σ²) ≤ Σwσ), so a cell whose hull has α = 0 everywhere can be skipped;
//   void prefetch(int voxel) const;   the cache lines of the cell based at a voxel;
//   template <class T, class F> void reconstruct(const Cell<T>&, MaskOf<T> live, const F& use)
//   const;
//       the model's random variable at the cell, built once as a Distribution1D over T
//       (distributions.h) and handed to use(d): load() takes expectedTf over it, and over double
//       probe, the references and the bivariate moments describe() it (distributionAt,
//       point_distribution.h);
//   static constexpr bool kLoadDeadLanes;   whether the ray loop loads lanes in empty cells too
//       (cheap loads need not wait for the emptiness test);
//   static K make(const ModelView&, const TfPiecesStorage&, const ClassifyOptions&,
//                 const ModelRow&);
//       the kernel over a model for a row of the model table (model_rows.h names K in its rows;
//       what differs between rows that share K is read from the row's fields, not its kind).
// Kernels are plain structs of sizes and pointers into storage that outlives them (a
// ModelVolume and the TfPiecesStorage owned by withKernel).
#include <cmath>
#include <cstddef>
#include <iterator>
#include <utility>
#include <variant>

#include "udvr/classify/distributions.h"
#include "udvr/classify/expected_tf.h"
#include "udvr/classify/model_kind.h"
#include "udvr/classify/tf_pieces.h"
#include "udvr/classify/transfer_function.h"
#include "udvr/reconstruct/box_spline.h"
#include "udvr/reconstruct/cell.h"
#include "udvr/reconstruct/gaussian_interp.h"
#include "udvr/reconstruct/gmm_ordered.h"
#include "udvr/reconstruct/quantile_interp.h"
#include "udvr/stats/model_view.h"

namespace udvr {

/// Gaussian supports for skipping are μ ± kSupportSigmas·σ (mass outside: 2·Φ(−6) ≈ 2e−9).
inline constexpr double kSupportSigmas = 6.0;
/// Uniform widths ≤ this × data range are folded into the shift (SPEC §3 uniform, exact).
inline constexpr double kUniformTinyWidth = 1e-9;
/// The fast uniform's width floor and point-mass threshold, × data range: keeps every division
/// away from 0 and z = t/σ ≤ 1e6 (its fourth power inside float's range).
inline constexpr double kUniformPointWidth = 1e-6;
/// Float lanes whose support is wider than this many times the TF's narrowest piece take the
/// double body of the fast uniform: the sum over breaks adds terms up to ~(total/piece)² before
/// they cancel. Measured float error (uniform_fast_test.cpp): 3e−6 at 128, 1.8e−5 at 512.
inline constexpr float kMaxFloatTotalOverPiece = 256.f;
/// Quantile widths ≤ this × data range are zero widths for quantile-mean (SPEC §4).
inline constexpr double kQuantileZeroWidth = 1e-12;

/// Options that change classification but are not part of the model file.
struct ClassifyOptions {
    int quartileDivisor = 4;     // quartile views need q divisible by this
    bool uniformMinMax = false;  // `--uniform-width minmax`: U[min, max] instead of μ ± √3σ
    /// The data range's width that scales zero-width thresholds (SPEC §4); 0: the model's own
    /// (modelDataRange). A probe of a cut-out neighbourhood passes the whole model's.
    double dataSpan = 0.0;
};

/// The model's data range (SPEC §4): [min b_0, max b_q] with quantiles, else [min of `min`,
/// max of `max`], else the range of `mean`. Used to scale zero-width thresholds.
std::pair<double, double> modelDataRange(const ModelView& model);

/// Throws UdvrError unless `model` has the arrays `kind` needs (sizes checked too).
void checkModelHasArrays(const ModelView& model, ModelKind kind,
                         const ClassifyOptions& options = {});

/// The quantile population [j0, j1] (boundary indices) of a quantile-range-family kind over the
/// model's q quantiles: quantile-range (0, q); the quartile views the boundaries at levels
/// (0, .25), (.25, .75), (.75, 1) — (0, q/4), (q/4, 3q/4), (3q/4, q) for even levels, which
/// need q divisible by options.quartileDivisor. Throws UdvrError where a level has no boundary.
std::pair<int, int> quantilePopulation(ModelKind kind, const ModelView& model,
                                       const ClassifyOptions& options = {});

/// The boundaries a quantile row of the model table classifies over (the 1D and 2D kernels
/// take them from here): the iqr array's two (stride 2, even levels), else the model's quantile
/// boundaries with the row's population [lo, hi] (quantilePopulation; quantile-mean rows: all,
/// 0 … q) and the model's levels (null: even). For the quantile-mean rows also Eq. 5's
/// weights: density (1/w_j) or equal, and the width at or below which a quantile is a point
/// mass (kQuantileZeroWidth × dataSpan; 0 for other rows).
struct QuantileBoundarySource {
    const float* data;
    int stride;  // floats per voxel
    int lo, hi;  // boundary indices of the population
    const double* levels;
    bool densityWeights = false;
    double zeroWidth = 0.0;  // data units
};
QuantileBoundarySource quantileBoundariesOf(const ModelView& model, const ModelRow& row,
                                            const ClassifyOptions& options);

/// The data range's width that scales a model's zero-width thresholds (SPEC §4):
/// options.dataSpan where set, else the model's own (modelDataRange).
inline double dataSpan(const ModelView& model, const ClassifyOptions& options) {
    if (options.dataSpan > 0.0) return options.dataSpan;
    const auto range = modelDataRange(model);
    return range.second - range.first;
}

/// A classified sample: (E[α·r], E[α·g], E[α·b], E[α]).
template <class T>
struct Classified {
    T v[4];
};

/// What every kernel holds: the cell geometry of its grid (1D and 2D TF kernels alike).
struct GridKernel {
    CellGeometry geometry;

    explicit GridKernel(const Grid3& grid) : geometry(grid) {}
    /// Whether int32 lane gathers reach every float of an array with perVoxel floats per voxel
    /// (else the lanes take the double body: their index would wrap past 2³¹).
    bool gathersFit(int perVoxel) const {
        return geometry.fitsInt32 &&
               static_cast<double>(geometry.stride[2]) * geometry.dims[2] * perVoxel < 2147483647.0;
    }
    /// Prefetch the four x-rows of the cell based at voxel v of an array with perVoxel floats.
    void prefetchRows(const float* a, int v, int perVoxel) const {
        const int g1 = geometry.next32[1], g2 = geometry.next32[2];
        for (int o : {0, g1, g2, g1 + g2}) {
            const float* p = a + static_cast<std::ptrdiff_t>(v + o) * perVoxel;
            __builtin_prefetch(p);
            if (perVoxel > 1) __builtin_prefetch(p + 2 * perVoxel - 1);
        }
    }
};

/// A 1D TF kernel: the grid and the TF in both real types.
struct KernelBase : GridKernel {
    TfPieces<double> tfExact;
    TfPieces<float> tfFast;

    KernelBase(const Grid3& grid, const TfPiecesStorage& tf)
        : GridKernel(grid), tfExact(tf.exact()), tfFast(tf.fast()) {}
    /// Whether reconstruct over lanes serves every batch: its lane gathers index the model's
    /// floats within int32 (else batches take the double body). True for the kernels that
    /// gather one float per voxel (the ray loop needs 32-bit voxel indices) or read transposed
    /// rows (64-bit addresses); the others say their own.
    bool lanesFit() const { return true; }
    /// The TF over T's real type.
    template <class T>
    UDVR_CPU_GPU const detail::TfFor<T>& tf() const {
        if constexpr (std::is_same_v<lanes::ScalarOf<T>, float>)
            return tfFast;
        else
            return tfExact;
    }
    /// f(tf) with the TF over T's real type; on lanes a view whose lookups are register
    /// permutes of the smallest table that holds the TF (lanes::kPermuteSizes), decided here
    /// once per call, not per lookup.
    template <class T, class F>
    UDVR_INLINE void withTf(const F& f) const {
        if constexpr (lanes::kIsVector<T>)
            withSizedTf<0>(f);
        else
            f(tf<T>());
    }
    template <int I, class F>
    UDVR_INLINE void withSizedTf(const F& f) const {
        if constexpr (I < static_cast<int>(std::size(lanes::kPermuteSizes))) {
            constexpr int kSize = lanes::kPermuteSizes[I];
            if (kSize > 0 && tfFast.breakCount < kSize)
                f(tfFast.template sized<kSize>());
            else
                withSizedTf<I + 1>(f);
        } else {
            f(tfFast);
        }
    }
};

namespace detail {
/// out ← 0 outside `live`.
template <class T>
UDVR_CPU_GPU inline void keepLive(lanes::MaskOf<T> live, T out[4]) {
    for (int ch = 0; ch < 4; ++ch) out[ch] = lanes::select(live, out[ch], T{});
}
/// The double body of kernel k in the `lanes` of a batch (out elsewhere unchanged): for models
/// without a float body, and for lanes a float body cannot serve accurately.
template <class K>
UDVR_NOINLINE void exactLanes(const K& k, const Cell<lanes::Vf>& cell, lanes::Mask which,
                              lanes::Vf out[4]) {
    for (std::uint32_t m = lanes::bits(which); m; m &= m - 1) {
        const int l = std::countr_zero(m);
        double v[4];
        k.finish(k.template load<double>(laneCell(cell, l), true), v);
        for (int ch = 0; ch < 4; ++ch) out[ch][l] = static_cast<float>(v[ch]);
    }
}
/// f(l, v) for each lane l of T in `which` (float and double: one lane, l = 0), writing the
/// double v[4] into lane l of out (other lanes unchanged): for what is written only in double.
template <class T, class F>
UDVR_INLINE void inDoublePerLane(lanes::MaskOf<T> which, T out[4], const F& f) {
    double v[4];
    if constexpr (lanes::kIsVector<T>) {
        for (std::uint32_t m = lanes::bits(which); m; m &= m - 1) {
            const int l = std::countr_zero(m);
            f(l, v);
            for (int ch = 0; ch < 4; ++ch) out[ch][l] = static_cast<float>(v[ch]);
        }
    } else if (which) {
        f(0, v);
        for (int ch = 0; ch < 4; ++ch) out[ch] = static_cast<T>(v[ch]);
    }
}
/// exactLanes for the lanes of T in `which` (a float thread: the double body when true; the
/// double body itself needs nothing).
template <class K, class T>
UDVR_CPU_GPU inline void exactWhere(const K& k, const Cell<T>& cell, lanes::MaskOf<T> which,
                                    T out[4]) {
    if constexpr (lanes::kIsVector<T>) {
        if (lanes::anyOf(which)) exactLanes(k, cell, which, out);
    } else if constexpr (!std::is_same_v<T, double>) {
        if (which) {
            double v[4];
            k.finish(
                k.template load<double>(Cell<double>{cell.base, cell.fx, cell.fy, cell.fz}, true),
                v);
            for (int ch = 0; ch < 4; ++ch) out[ch] = static_cast<T>(v[ch]);
        }
    }
}
/// Kernels that classify in load(): finish() hands the result on.
struct ClassifyInLoad {
    template <class T>
    using Loaded = Classified<T>;
    static constexpr bool kLoadDeadLanes = false;
    template <class T>
    UDVR_CPU_GPU static void finish(const Classified<T>& c, T out[4]) {
        for (int ch = 0; ch < 4; ++ch) out[ch] = c.v[ch];
    }
};
/// use(boundary, width, windowed) with callables boundary(j), width(j) over boundaries first …
/// first + count − 1 of a voxel-major array (`stride` floats per voxel; widths only where
/// `widths`) at a cell (Eq. 2): on lanes the batch's transposed rows where they fit
/// (kMaxRowBoundaries; windowed = true), else one trilinear blend per boundary. Dead lanes are 0.
/// Lanes whose int32 float index would pass 2³¹ must not come here (gathersFit).
template <class T, class Use>
UDVR_CPU_GPU UDVR_INLINE void quantileRows(const CellGeometry& g, const float* data, int stride,
                                           int first, int count, bool widths, const Cell<T>& c,
                                           lanes::MaskOf<T> live, const Use& use) {
    if constexpr (lanes::kIsVector<T>) {
        if (count <= kMaxRowBoundaries) {
            lanes::Vf b[kMaxRowBoundaries], w[kMaxRowBoundaries];
            boundaryRows(g, data, stride, first, count, c, live, b, widths ? w : nullptr);
            use([&](int j) UDVR_INLINE_LAMBDA { return b[j]; },
                [&](int j) UDVR_INLINE_LAMBDA { return w[j]; }, true);
            return;
        }
    }
    use([&](int j)
            UDVR_INLINE_LAMBDA { return boundaryAt<T>(g, data, stride, first + j, c, live); },
        [&](int j) UDVR_INLINE_LAMBDA { return widthAt<T>(g, data, stride, first + j, c, live); },
        false);
}
/// out ← E[TF] over the distribution d of kernel k at a cell in the `live` lanes (0 elsewhere):
/// the one expectation of d's kind (distributions.h); float lanes it cannot serve accurately
/// (tooWideForFloat, for the kinds that have such a limit) take k's double body.
template <class T, class K, class D>
UDVR_CPU_GPU UDVR_INLINE void classifyOver(const K& k, const Cell<T>& c, const D& d,
                                           lanes::MaskOf<T> live, T out[4]) {
    if constexpr (!std::is_same_v<T, double> && hasFloatLimit<D>) {
        const auto wide = live & tooWideForFloat(d, k.tfFast.narrowestPiece);
        k.template withTf<T>([&](const auto& t)
                                 UDVR_INLINE_LAMBDA { expectedTf(t, d, live & !wide, out); });
        exactWhere(k, c, wide, out);
    } else {
        k.template withTf<T>([&](const auto& t)
                                 UDVR_INLINE_LAMBDA { expectedTf(t, d, live, out); });
    }
    keepLive<T>(live, out);
}
/// Whether lanes of T would gather past int32 indices in kernel k's arrays (k.lanesFit(); then
/// the batch takes the double body).
template <class T, class K>
UDVR_INLINE bool gathersPastInt32(const K& k) {
    if constexpr (lanes::kIsVector<T>)
        return !k.lanesFit();
    else
        return false;
}
/// The load of a quantile kernel k: reconstruct + classifyOver; a batch whose boundaries take
/// the gather path past int32 indices (k.lanesFit()) takes the double body.
template <class T, class K>
UDVR_CPU_GPU UDVR_INLINE Classified<T> quantileKernelLoad(const K& k, const Cell<T>& c,
                                                          lanes::MaskOf<T> live) {
    Classified<T> r;
    if (gathersPastInt32<T>(k)) {
        r = Classified<T>{};
        exactWhere(k, c, live, r.v);
        return r;
    }
    k.template reconstruct<T>(
        c, live, [&](const auto& d) UDVR_INLINE_LAMBDA { classifyOver<T>(k, c, d, live, r.v); });
    return r;
}
}  // namespace detail

/// Classify at an index-space point (clamped into the grid) with the body over T.
template <class T, class K>
UDVR_CPU_GPU inline void classifyAt(const K& k, float x, float y, float z, T out[4]) {
    const Cell<T> cell = cellAt<T>(k.geometry, x, y, z);
    k.finish(k.template load<T>(cell, lanes::allTrue<T>()), out);
}
/// classifyAt with the exact (double) body, as an Rgba.
template <class K>
inline Rgba classifyExact(const K& k, float x, float y, float z) {
    double v[4];
    classifyAt<double>(k, x, y, z, v);
    return Rgba{static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2]),
                static_cast<float>(v[3])};
}

/// Mean field (SPEC §3–4 `mean`; also plain fields and each gmm-mc realization): TF(Σ w_c μ_c).
struct MeanKernel : KernelBase {
    const float* values;  // one per grid point

    MeanKernel(const Grid3& grid, const float* v, const TfPiecesStorage& tf)
        : KernelBase(grid, tf), values(v) {}
    /// The kernel over `model` for a row of the model table (model_rows.h).
    static MeanKernel make(const ModelView& m, const TfPiecesStorage& tf, const ClassifyOptions&,
                           const ModelRow&) {
        return MeanKernel(m.grid, m.mean.data(), tf);
    }
    template <class T>
    using Loaded = T;
    static constexpr bool kLoadDeadLanes = true;
    /// Its distribution at a cell: the interpolated value, a point mass.
    template <class T, class Use>
    UDVR_CPU_GPU UDVR_INLINE void reconstruct(const Cell<T>& c, lanes::MaskOf<T> live,
                                              const Use& use) const {
        use(PointMass<T>{trilinear(geometry, values, 1, c, live)});
    }
    /// The value (the ray loop loads every lane, then classifies the live ones in finish).
    template <class T>
    UDVR_CPU_GPU UDVR_INLINE T load(const Cell<T>& c, lanes::MaskOf<T> live) const {
        T value{};
        reconstruct<T>(c, live, [&](const PointMass<T>& d) UDVR_INLINE_LAMBDA { value = d.x; });
        return value;
    }
    template <class T>
    UDVR_CPU_GPU UDVR_INLINE void finish(T value, T out[4]) const {
        withTf<T>([&](const auto& t) UDVR_INLINE_LAMBDA {
            expectedTf(t, PointMass<T>{value}, lanes::allTrue<T>(), out);
        });
    }
    void voxelSupport(std::size_t v, float& lo, float& hi) const { lo = hi = values[v]; }
    void prefetch(int v) const { prefetchRows(values, v, 1); }
};

/// The uniform voxels' intervals (SPEC §2), shared by the 1D and 2D uniform kernels:
/// [first, second] = [min, max] with `--uniform-width minmax`, else μ ± √3σ from first = mean,
/// second = stddev.
struct UniformVoxels {
    const float* first;
    const float* second;
    bool minMax;

    UDVR_CPU_GPU void interval(std::int64_t voxel, double& lo, double& hi) const {
        if (minMax) {
            lo = first[voxel];
            hi = second[voxel];
        } else {
            const double h = 1.7320508075688772 * static_cast<double>(second[voxel]);
            lo = static_cast<double>(first[voxel]) - h;
            hi = static_cast<double>(first[voxel]) + h;
        }
    }
    void voxelSupport(std::size_t voxel, float& lo, float& hi) const {
        double l, h;
        interval(static_cast<std::int64_t>(voxel), l, h);
        lo = static_cast<float>(l);
        hi = static_cast<float>(h);
    }
};

/// Uniform (box spline, SPEC §3): X = Σ w_c U[lo_c, hi_c]. `uniform` (`exact`) takes the exact
/// box spline in double (SPEC §4's 1e−4; every lane of a batch takes the double body);
/// `uniform-fast` the fast form over T (BoxSplineFast: the two widest boxes exact, the rest a
/// Gaussian with κ4, κ6 terms; issue 12), within 4e−4 of it. lo/hi = μ ∓ √3σ (`first` = mean,
/// `second` = stddev) or [min, max]
/// (`minMax`).
struct UniformKernel : KernelBase, UniformVoxels, detail::ClassifyInLoad {
    double tinyWidth;  // data units; exact: widths at or below go into the shift
    bool exact;
    double pointWidth;    // data units; fast: sums this narrow are point masses, widths ≥ it
    float maxFloatTotal;  // data units; wider float lanes take the double body
                          // (kMaxFloatTotalOverPiece)

    UniformKernel(const Grid3& grid, const float* a, const float* b, bool mm, double tiny,
                  const TfPiecesStorage& tf, bool exactIn = false, double point = 0.0)
        : KernelBase(grid, tf),
          UniformVoxels{a, b, mm},
          tinyWidth(tiny),
          exact(exactIn),
          pointWidth(point),
          maxFloatTotal(kMaxFloatTotalOverPiece * tf.fast().narrowestPiece) {}
    /// The kernel over `model` for a row of the model table (model_rows.h).
    static UniformKernel make(const ModelView& m, const TfPiecesStorage& tf,
                              const ClassifyOptions& o, const ModelRow& row) {
        const double s = dataSpan(m, o);
        return UniformKernel(m.grid, o.uniformMinMax ? m.min.data() : m.mean.data(),
                             o.uniformMinMax ? m.max.data() : m.stddev.data(), o.uniformMinMax,
                             kUniformTinyWidth * s, tf, row.exactForm, kUniformPointWidth * s);
    }
    /// Its distribution at a cell: the box spline of the 8 corners' intervals (SPEC §3
    /// uniform), loaded by x-edges; `uniform-fast` takes the fast form's expectation over it.
    template <class T, class Use>
    UDVR_CPU_GPU UDVR_INLINE void reconstruct(const Cell<T>& c, lanes::MaskOf<T> live,
                                              const Use& use) const {
        using S = lanes::ScalarOf<T>;
        CornerBoxSpline<T> d;
        d.tinyWidth = tinyWidth;
        d.pointWidth = pointWidth;
        d.exact = exact;
        trilinearWeights(c, d.w);
        const std::int64_t offsets[4] = {0, geometry.next[1], geometry.next[2],
                                         geometry.next[1] + geometry.next[2]};
        for (int r = 0; r < 4; ++r) {  // corners 2r (x0) and 2r + 1 (x1) of row r = (y, z)
            T a[2], b[2];
            edgeOf<T>(geometry, first, 1, c.base, offsets[r], live, a[0], a[1]);
            edgeOf<T>(geometry, second, 1, c.base, offsets[r], live, b[0], b[1]);
            for (int x = 0; x < 2; ++x) {
                const T h = b[x] * S(1.7320508075688772);
                d.lo[2 * r + x] = minMax ? a[x] : a[x] - h;
                d.hi[2 * r + x] = minMax ? b[x] : a[x] + h;
            }
        }
        use(d);
    }
    /// Its corners' intervals are gathered, one float per voxel per array.
    bool lanesFit() const { return gathersFit(1); }
    template <class T>
    UDVR_CPU_GPU UDVR_INLINE Classified<T> load(const Cell<T>& c, lanes::MaskOf<T> live) const {
        using S = lanes::ScalarOf<T>;
        Classified<T> r{};
        if constexpr (std::is_same_v<T, double>) {
            reconstruct<T>(c, live, [&](const CornerBoxSpline<T>& d) UDVR_INLINE_LAMBDA {
                expectedTf(tfExact, d, live, r.v);
            });
            return r;
        }
        if (exact || detail::gathersPastInt32<T>(*this)) {
            detail::exactWhere(*this, c, live, r.v);
            return r;
        }
        reconstruct<T>(c, live, [&](const CornerBoxSpline<T>& d) UDVR_INLINE_LAMBDA {
            // Float lanes whose support is wide against the TF's narrowest piece take the
            // double body (kMaxFloatTotalOverPiece).
            const BoxSplineFast<T> b = d.fast();
            const auto wide = live & (b.total > maxFloatTotal);
            withTf<T>([&](const auto& t) UDVR_INLINE_LAMBDA {
                expectedTfUniformFast<T>(t, b, static_cast<S>(pointWidth), live & !wide, r.v);
            });
            detail::exactWhere(*this, c, wide, r.v);
            detail::keepLive<T>(live, r.v);
        });
        return r;
    }
    using UniformVoxels::voxelSupport;
    void prefetch(int v) const {
        if (exact) return;
        prefetchRows(first, v, 1);
        prefetchRows(second, v, 1);
    }
};

/// Gaussian (SPEC §3–4): N(Σ w_c μ_c, Σ w_c² σ_c²), E[TF] in closed form per TF piece.
struct GaussianKernel : KernelBase, detail::ClassifyInLoad {
    const float* mean;
    const float* stddev;

    GaussianKernel(const Grid3& grid, const float* m, const float* s, const TfPiecesStorage& tf)
        : KernelBase(grid, tf), mean(m), stddev(s) {}
    /// The kernel over `model` for a row of the model table (model_rows.h).
    static GaussianKernel make(const ModelView& m, const TfPiecesStorage& tf,
                               const ClassifyOptions&, const ModelRow&) {
        return GaussianKernel(m.grid, m.mean.data(), m.stddev.data(), tf);
    }
    /// Its distribution at a cell: N(μ, σ²) (reconstruct/gaussian_interp.h), a point where σ = 0.
    template <class T, class Use>
    UDVR_CPU_GPU UDVR_INLINE void reconstruct(const Cell<T>& c, lanes::MaskOf<T> live,
                                              const Use& use) const {
        NormalDistribution<T> d;
        gaussianAt(geometry, mean, stddev, c, live, d.mu, d.sigma);
        use(d);
    }
    template <class T>
    UDVR_CPU_GPU UDVR_INLINE Classified<T> load(const Cell<T>& c, lanes::MaskOf<T> live) const {
        Classified<T> r;
        reconstruct<T>(c, live, [&](const NormalDistribution<T>& d) UDVR_INLINE_LAMBDA {
            detail::classifyOver<T>(*this, c, d, live, r.v);
        });
        return r;
    }
    void voxelSupport(std::size_t voxel, float& lo, float& hi) const {
        const double s = kSupportSigmas * static_cast<double>(stddev[voxel]);
        lo = static_cast<float>(mean[voxel] - s);
        hi = static_cast<float>(mean[voxel] + s);
    }
    void prefetch(int v) const {
        prefetchRows(mean, v, 1);
        prefetchRows(stddev, v, 1);
    }
};

/// GMM (ordered) (Hollister & Pang 2013; SPEC §3–4): per rank k, π_k, μ_k, σ_k interpolated
/// trilinearly from the corners' k'th components, π normalised to Σπ = 1 (left 0 where all are
/// 0), then Σ_k π_k·E[TF(N(μ_k, σ_k²))].
struct GmmOrderedKernel : KernelBase, detail::ClassifyInLoad {
    const float* gmm;  // π_1..π_K, μ_1..μ_K, σ_1..σ_K per voxel
    int components;    // K ≤ kMaxKernelGmmComponents

    GmmOrderedKernel(const Grid3& grid, const float* g, int k, const TfPiecesStorage& tf)
        : KernelBase(grid, tf), gmm(g), components(k) {}
    /// The kernel over `model` for a row of the model table (model_rows.h).
    static GmmOrderedKernel make(const ModelView& m, const TfPiecesStorage& tf,
                                 const ClassifyOptions&, const ModelRow&) {
        return GmmOrderedKernel(m.grid, m.gmm.data(), m.gmmComponents, tf);
    }
    /// Its distribution at a cell: the mixture of π_k (normalised), μ_k, σ_k
    /// (reconstruct/gmm_ordered.h); no mass where every weight is 0.
    template <class T, class Use>
    UDVR_CPU_GPU UDVR_INLINE void reconstruct(const Cell<T>& c, lanes::MaskOf<T> live,
                                              const Use& use) const {
        NormalMixture<T> d;
        d.k = components;
        gmmOrderedAt(geometry, gmm, components, c, live, d.pi, d.mu, d.sigma);
        use(d);
    }
    /// π, μ, σ are gathered from 3K floats per voxel.
    bool lanesFit() const { return gathersFit(3 * components); }
    template <class T>
    UDVR_CPU_GPU UDVR_INLINE Classified<T> load(const Cell<T>& c, lanes::MaskOf<T> live) const {
        Classified<T> r{};
        if (detail::gathersPastInt32<T>(*this)) {
            detail::exactWhere(*this, c, live, r.v);
            return r;
        }
        reconstruct<T>(c, live, [&](const NormalMixture<T>& d) UDVR_INLINE_LAMBDA {
            detail::classifyOver<T>(*this, c, d, live, r.v);
        });
        return r;
    }
    void voxelSupport(std::size_t voxel, float& lo, float& hi) const {
        const float* g = gmm + voxel * 3 * static_cast<std::size_t>(components);
        double l = INFINITY, h = -INFINITY;
        for (int k = 0; k < components; ++k) {
            if (!(g[k] > 0.f)) continue;
            const double s = kSupportSigmas * static_cast<double>(g[2 * components + k]);
            l = std::fmin(l, g[components + k] - s);
            h = std::fmax(h, g[components + k] + s);
        }
        if (l > h) l = h = g[components];  // all weights 0: any component mean
        lo = static_cast<float>(l);
        hi = static_cast<float>(h);
    }
    void prefetch(int v) const { prefetchRows(gmm, v, 3 * components); }
};

/// Quantile range (Eq. 4) over the quantiles j0+1 … j1 of boundaries stored with `stride`
/// floats per voxel: quantile-range (0…q), the quartile views (0…q/4, q/4…3q/4, 3q/4…q) and iqr
/// (the 2-boundary iqr array, 0…1).
struct QuantileRangeKernel : KernelBase, detail::ClassifyInLoad {
    const float* boundaries;
    int stride;             // boundaries per voxel
    int j0, j1;             // population: quantiles j0+1 … j1
    QuantileLevels levels;  // of boundaries j0 …

    /// `levels`: the model's t_0 … t_q (null: even).
    QuantileRangeKernel(const Grid3& grid, const float* b, int s, int lo, int hi,
                        const double* levelsIn, const TfPiecesStorage& tf)
        : KernelBase(grid, tf), boundaries(b), stride(s), j0(lo), j1(hi), levels{levelsIn, lo} {}
    /// The kernel over `model` for a row of the model table (model_rows.h).
    static QuantileRangeKernel make(const ModelView& m, const TfPiecesStorage& tf,
                                    const ClassifyOptions& o, const ModelRow& row) {
        const QuantileBoundarySource b = quantileBoundariesOf(m, row, o);
        return QuantileRangeKernel(m.grid, b.data, b.stride, b.lo, b.hi, b.levels, tf);
    }
    /// Its distribution at a cell (Eq. 2 and 4): the rank population j0 … j1, each quantile
    /// uniform between its boundaries with its share of the population's mass.
    template <class T, class Use>
    UDVR_CPU_GPU UDVR_INLINE void reconstruct(const Cell<T>& c, lanes::MaskOf<T> live,
                                              const Use& use) const {
        const int count = j1 - j0 + 1;
        detail::quantileRows<T>(
            geometry, boundaries, stride, j0, count, false, c, live,
            [&](const auto& boundary, const auto&, bool windowed) UDVR_INLINE_LAMBDA {
                use(QuantilePopulation<T, decltype(boundary)>{boundary, count, levels, windowed});
            });
    }
    /// Boundaries past kMaxRowBoundaries are gathered (quantileRows), `stride` floats per voxel.
    bool lanesFit() const { return j1 - j0 + 1 <= kMaxRowBoundaries || gathersFit(stride); }
    template <class T>
    UDVR_CPU_GPU UDVR_INLINE Classified<T> load(const Cell<T>& c, lanes::MaskOf<T> live) const {
        return detail::quantileKernelLoad<T>(*this, c, live);
    }
    void voxelSupport(std::size_t voxel, float& lo, float& hi) const {
        const float* b = boundaries + voxel * static_cast<std::size_t>(stride);
        lo = b[j0];
        hi = b[j1];
    }
    void prefetch(int v) const { prefetchRows(boundaries + j0, v, stride); }
};

/// Quantile mean (Eq. 5) with density weights p_j ∝ 1/w_j (`quantile-mean`) or equal weights
/// (`quantile-mean-mass`).
struct QuantileMeanKernel : KernelBase, detail::ClassifyInLoad {
    const float* quantiles;
    int q;
    QuantileLevels levels;
    bool densityWeights;
    double zeroWidth;  // data units

    /// `levels`: the model's t_0 … t_q (null: even).
    QuantileMeanKernel(const Grid3& grid, const float* b, int qIn, const double* levelsIn,
                       bool density, double zero, const TfPiecesStorage& tf)
        : KernelBase(grid, tf),
          quantiles(b),
          q(qIn),
          levels{levelsIn, 0},
          densityWeights(density),
          zeroWidth(zero) {}
    /// The kernel over `model` for a row of the model table (model_rows.h).
    static QuantileMeanKernel make(const ModelView& m, const TfPiecesStorage& tf,
                                   const ClassifyOptions& o, const ModelRow& row) {
        const QuantileBoundarySource b = quantileBoundariesOf(m, row, o);
        return QuantileMeanKernel(m.grid, b.data, b.hi - b.lo, b.levels, b.densityWeights,
                                  b.zeroWidth, tf);
    }
    /// Its distribution at a cell (Eq. 5): a point mass at each quantile's midpoint with
    /// forEachQuantileMeanWeight's share, every one of the q (mass 0 included), in order.
    template <class T, class Use>
    UDVR_CPU_GPU UDVR_INLINE void reconstruct(const Cell<T>& c, lanes::MaskOf<T> live,
                                              const Use& use) const {
        detail::quantileRows<T>(
            geometry, quantiles, q + 1, 0, q + 1, densityWeights, c, live,
            [&](const auto& boundary, const auto& width, bool windowed) UDVR_INLINE_LAMBDA {
                use(QuantileMidpoints<T, decltype(boundary), decltype(width)>{
                    boundary, width, q, levels, densityWeights, zeroWidth, windowed});
            });
    }
    /// Boundaries past kMaxRowBoundaries are gathered (quantileRows), q + 1 floats per voxel.
    bool lanesFit() const { return q + 1 <= kMaxRowBoundaries || gathersFit(q + 1); }
    template <class T>
    UDVR_CPU_GPU UDVR_INLINE Classified<T> load(const Cell<T>& c, lanes::MaskOf<T> live) const {
        return detail::quantileKernelLoad<T>(*this, c, live);
    }
    /// The TF is only evaluated at quantile midpoints, and the midpoints at a point interpolate
    /// the corners' midpoints (m_j(p) = Σ w_c m_{j,c}), so [m_0, m_{q−1}] of each voxel is a
    /// support: narrower than [b_0, b_q] by half the outer quantiles (often the outliers).
    void voxelSupport(std::size_t voxel, float& lo, float& hi) const {
        const float* b = quantiles + voxel * (static_cast<std::size_t>(q) + 1);
        lo = static_cast<float>(0.5 * (static_cast<double>(b[0]) + b[1]));
        hi = static_cast<float>(0.5 * (static_cast<double>(b[q - 1]) + b[q]));
    }
    void prefetch(int v) const { prefetchRows(quantiles, v, q + 1); }
};

/// The ensemble's own expected classification (`members`, no model; issue 12): each member
/// f_i interpolated trilinearly as the mean field is, then E[α·c] = (1/n) Σ_i α(f_i)·c(f_i) and
/// E[α] = (1/n) Σ_i α(f_i). Keeps every spatial correlation of the ensemble.
struct MembersKernel : KernelBase, detail::ClassifyInLoad {
    const float* members;  // n per voxel, voxel-major: members[v·n + i]
    int n;

    MembersKernel(const Grid3& grid, const float* m, int count, const TfPiecesStorage& tf)
        : KernelBase(grid, tf), members(m), n(count) {}
    /// The kernel over `model` for a row of the model table (model_rows.h).
    static MembersKernel make(const ModelView& m, const TfPiecesStorage& tf, const ClassifyOptions&,
                              const ModelRow&) {
        return MembersKernel(m.grid, m.members.data(), m.memberCount, tf);
    }
    /// Its distribution at a cell: a point mass 1/n at each member, interpolated as the mean
    /// field is (Σ_c w_c f_{i,c} by lerps); on lanes blocks of members as the batch's transposed
    /// rows (contiguous per voxel).
    template <class T, class Use>
    UDVR_CPU_GPU UDVR_INLINE void reconstruct(const Cell<T>& c, lanes::MaskOf<T> live,
                                              const Use& use) const {
        const auto values = [&](int first, int count, T* f) UDVR_INLINE_LAMBDA {
            if constexpr (lanes::kIsVector<T>) {
                boundaryRows(geometry, members, n, first, count, c, live, f);
            } else {
                for (int i = 0; i < count; ++i)
                    f[i] = boundaryAt<T>(geometry, members, n, first + i, c, live);
            }
        };
        use(EqualMasses<T, decltype(values)>{values, n});
    }
    template <class T>
    UDVR_CPU_GPU UDVR_INLINE Classified<T> load(const Cell<T>& c, lanes::MaskOf<T> live) const {
        Classified<T> r;
        reconstruct<T>(c, live, [&](const auto& d) UDVR_INLINE_LAMBDA {
            detail::classifyOver<T>(*this, c, d, live, r.v);
        });
        return r;
    }
    /// [min, max] over the voxel's members: each f_i(p) is a convex blend of its corners.
    void voxelSupport(std::size_t voxel, float& lo, float& hi) const {
        const float* f = members + voxel * static_cast<std::size_t>(n);
        lo = hi = f[0];
        for (int i = 1; i < n; ++i) {
            lo = f[i] < lo ? f[i] : lo;
            hi = f[i] > hi ? f[i] : hi;
        }
    }
    void prefetch(int v) const { prefetchRows(members, v, n); }
};

}  // namespace udvr
