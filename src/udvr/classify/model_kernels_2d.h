#pragma once
// Kernels for 2D transfer functions (SPEC §9): x the value at the sample, y the gradient
// magnitude G = n̂·Y along the mean gradient n̂ = μ_Y/|μ_Y| (+x where μ_Y = 0). The same
// interface as the 1D kernels (model_kernels.h), so the same ray loop and probe serve them.
// Each gives its (X, G) at a cell as pieces into a JointDistributionSink (jointDistributionAt,
// joint_distribution.h). The kernels with lane bodies (mean, the quantile family) build that
// distribution once, over the lane type, in `reconstruct<T>(cell, live, use)`
// (distributions_2d.h): `load` takes a TF2's expectation over it (detail::classify2DOver),
// jointDistributionAt describes reconstruct<double>'s; so do the 2D gaussian (JointNormal) and
// the 2D uniform (JointBoxSpline).
//
// Gradients come from grid gradients computed once per model (reconstruct/gradient_field.h):
// the sample's gradient is their trilinear blend, which is SPEC §9's 32-voxel form exactly.
// The mean gradient μ_Y blends the grid gradients of the `mean` array (every model); the quantile
// models blend, per boundary j, the grid gradients of the field of every voxel's boundary j
// (the rank coupling: all voxels at the same rank).
#include <array>
#include <bit>
#include <cmath>
#include <tuple>

#include "udvr/classify/distributions_2d.h"
#include "udvr/classify/expected_tf.h"
#include "udvr/classify/expected_tf2.h"
#include "udvr/classify/expected_tf2_fast.h"
#include "udvr/classify/expected_tf2_gaussian.h"
#include "udvr/classify/expected_tf2_uniform_exact.h"
#include "udvr/classify/model_kernels.h"
#include "udvr/reconstruct/cell.h"
#include "udvr/reconstruct/gradient.h"
#include "udvr/reconstruct/gradient_field.h"
#include "udvr/reconstruct/quantile_interp.h"
#include "udvr/util/check.h"

namespace udvr {

/// Boundaries a 2D quantile kernel handles per sample (q ≤ 127).
inline constexpr int kMaxBoundaries2D = 128;
static_assert(kMaxBoundaries2D <= kMaxPolylineVertices);
/// Gradient components (3 for the mean, 3 per boundary) a batch blends from its rows
/// (Quantile2DKernel): q ≤ 19 on AVX-512, 8 on AVX2, 3 on SSE2/NEON; more take trilinear gathers.
inline constexpr int kMaxGradientRows = 4 * lanes::kWidth;

/// Where a 2D kernel reads the grid gradients of the `mean` array (world units): component a of
/// voxel v at data[v·perVoxel + a·componentStep]. gridGradients' Planes: (1, N); ValueRows:
/// (4, 1), data at the first row's x; the quantile kernels' VoxelRows with the mean leading:
/// (3L, L).
struct MeanGradientView {
    const float* data = nullptr;
    int perVoxel = 1;
    std::size_t componentStep = 0;
};

/// What every 2D kernel holds: the grid, the TF2 raster over double and float, and where the
/// grid gradients of the `mean` array are.
struct Kernel2DBase : GridKernel {
    Tf2Raster<double> tfExact;
    Tf2Raster<float> tfFast;
    MeanGradientView meanGradient;

    Kernel2DBase(const Grid3& grid, const Tf2Raster<double>& exact, const Tf2Raster<float>& fast,
                 const MeanGradientView& meanGrad)
        : GridKernel(grid), tfExact(exact), tfFast(fast), meanGradient(meanGrad) {}
    /// The raster over T's real type.
    template <class T>
    UDVR_CPU_GPU const Tf2Raster<lanes::ScalarOf<T>>& tf2() const {
        if constexpr (std::is_same_v<lanes::ScalarOf<T>, float>)
            return tfFast;
        else
            return tfExact;
    }
    /// μ_Y at a cell: the trilinear blend of the mean's grid gradients.
    template <class T>
    UDVR_CPU_GPU UDVR_INLINE void meanGradientAt(const Cell<T>& c, lanes::MaskOf<T> live,
                                                 T y[3]) const {
        for (int a = 0; a < 3; ++a)
            y[a] = trilinear(geometry, meanGradient.data + a * meanGradient.componentStep,
                             meanGradient.perVoxel, c, live);
    }
    /// n̂ = μ_Y/|μ_Y| (+x where |μ_Y| = 0) and |μ_Y| at a cell. The components are scaled by
    /// their largest magnitude before squaring, so float neither underflows (|μ_Y| < 1e−19) nor
    /// overflows.
    template <class T>
    UDVR_CPU_GPU UDVR_INLINE T meanDirectionAt(const Cell<T>& c, lanes::MaskOf<T> live,
                                               T n[3]) const {
        T y[3];
        meanGradientAt(c, live, y);
        return directionOf(y, n);
    }
    /// The base voxel (i, j, k) of each live lane's cell (0 in dead lanes). Needs gathersFit(1).
    void baseIndices(const Cell<lanes::Vf>& c, lanes::Mask live, lanes::Vi idx[3]) const {
        using lanes::Vi;
        using Vd = lanes::Vec<double, lanes::kWidth>;
        // (n + ½)·(1/d) in double is n/d to well under ½/d for n < 2⁵¹, so its truncation is
        // the quotient.
        const auto divide = [](Vi n, std::int64_t d) {
            const Vd q = (__builtin_convertvector(n, Vd) + 0.5) * (1.0 / static_cast<double>(d));
            return __builtin_convertvector(q, Vi);
        };
        const Vi base = lanes::select(live, c.base, Vi{});
        idx[2] = divide(base, geometry.stride[2]);
        const Vi rem = base - idx[2] * geometry.stride32[2];
        idx[1] = divide(rem, geometry.stride[1]);
        idx[0] = rem - idx[1] * geometry.stride32[1];
    }
    /// The live lanes whose cell's 32-voxel form has only central differences: base voxel
    /// (i, j, k) with 1 ≤ i ≤ dims − 3 on each axis (the cell and its 24 outer neighbours inside
    /// the grid). Needs gathersFit(1).
    lanes::Mask interiorLanes(const Cell<lanes::Vf>& c, lanes::Mask live) const {
        lanes::Vi idx[3];
        baseIndices(c, live, idx);
        lanes::Mask inside = live;
        for (int a = 0; a < 3; ++a)
            inside = inside & (idx[a] >= 1) & (idx[a] <= geometry.dims[a] - 3);
        return inside;
    }
    /// n̂ and |μ_Y| of a given μ_Y = y (meanDirectionAt).
    template <class T>
    UDVR_CPU_GPU UDVR_INLINE static T directionOf(const T y[3], T n[3]) {
        using S = lanes::ScalarOf<T>;
        const T m = lanes::max(lanes::max(lanes::abs(y[0]), lanes::abs(y[1])), lanes::abs(y[2]));
        const auto zero = !(m > S(0));
        const T inv = S(1) / lanes::select(zero, lanes::splat<T>(S(1)), m);
        T r[3];
        for (int a = 0; a < 3; ++a) r[a] = y[a] * inv;
        const T len = lanes::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);  // in [1, √3]
        const T invLen = S(1) / lanes::select(zero, lanes::splat<T>(S(1)), len);
        n[0] = lanes::select(zero, lanes::splat<T>(S(1)), r[0] * invLen);
        n[1] = lanes::select(zero, T{}, r[1] * invLen);
        n[2] = lanes::select(zero, T{}, r[2] * invLen);
        return lanes::select(zero, T{}, m * len);
    }
};

namespace detail {
/// out ← E[TF2] over the joint distribution that the 2D kernel k reconstructs at a cell, in the
/// `live` lanes (0 elsewhere): the one expectation of its kind (distributions_2d.h) over the
/// raster of T's real type.
template <class T, class K>
UDVR_CPU_GPU UDVR_INLINE void classify2DOver(const K& k, const Cell<T>& c, lanes::MaskOf<T> live,
                                             T out[4]) {
    k.reconstruct(c, live, [&](const auto& d) UDVR_INLINE_LAMBDA {
        expectedTf2(k.template tf2<T>(), d, live, out);
    });
    keepLive<T>(live, out);
}
}  // namespace detail

/// Mean field and ground truth with a TF2 (SPEC §9 `mean`): TF2(x̄, |μ_Y|). Value and gradient
/// come from one row of 4 floats per voxel (gridGradients' ValueRows): a batch reads the rows
/// with plain loads and blends the four floats at once (rows4; 512² tangle, one thread:
/// 127 → 97 ms against four trilinears of 64-bit pair gathers), in the lerp order of
/// trilinear, so the values are the same to the bit.
struct Mean2DKernel : Kernel2DBase, detail::ClassifyInLoad {
    const float* rows;  // per grid point: the value (`mean` array, or a plain field), ∇ x, y, z

    Mean2DKernel(const Grid3& grid, const float* valueRows, const Tf2Raster<double>& exact,
                 const Tf2Raster<float>& fast)
        : Kernel2DBase(grid, exact, fast, {valueRows + 1, 4, 1}), rows(valueRows) {}
    /// The kernel over `m` for a row of the model table (model_rows.h) with a TF2: `s` (a
    /// Tf2Setup, model_families.h) holds the TF2's views and the gradients, and outlives it.
    template <class Setup>
    static Mean2DKernel make(const ModelView& m, Setup& s, const ClassifyOptions&,
                             const ModelRow&) {
        return Mean2DKernel(
            m.grid,
            s.gradients.of(m.grid, m.mean.data(), 1, 0, 1, GradientLayout::ValueRows).data(),
            s.exact, s.fast);
    }
    /// Its distribution at a cell: the point (x̄, |μ_Y|) (JointPoint), handed to use(d).
    template <class T, class Use>
    UDVR_CPU_GPU UDVR_INLINE void reconstruct(const Cell<T>& c, lanes::MaskOf<T> live,
                                              const Use& use) const {
        T x, y[3];
        if constexpr (lanes::kIsVector<T>) {  // rows4 indexes in 64 bits: no gathersFit
            lanes::Vf q[4];                   // value, ∇ x, y, z
            rows4(geometry, rows, c, live, q);
            x = q[0];
            for (int a = 0; a < 3; ++a) y[a] = q[1 + a];
        } else {
            x = trilinear(geometry, rows, 4, c, live);
            meanGradientAt(c, live, y);
        }
        T n[3];
        use(JointPoint<T>{x, directionOf(y, n)});
    }
    template <class T>
    UDVR_CPU_GPU UDVR_INLINE Classified<T> load(const Cell<T>& c, lanes::MaskOf<T> live) const {
        Classified<T> r;
        detail::classify2DOver<T>(*this, c, live, r.v);
        return r;
    }
    void voxelSupport(std::size_t v, float& lo, float& hi) const { lo = hi = rows[4 * v]; }
    void prefetch(int v) const { prefetchRows(rows, v, 4); }
};

/// Gaussian with a TF2 (SPEC §9): independent normal voxels X_i ~ N(μ_i, σ_i²); (X, G) =
/// Σ_i (w_i, u_i) X_i over the 32-voxel form (u_i = n̂·g_i) is bivariate normal with means
/// (Σ w_i μ_i, n̂·μ_Y) and covariance Σ_i (w_i, u_i)ᵀ(w_i, u_i) σ_i² (JointNormal,
/// distributions_2d.h). E[TF2] by the prefiltered tables (`gaussian`: Tf2BlurTables::gaussian,
/// expected_tf2_fast.h; over lanes the moments and the table sums in float) or, without them
/// (`gaussian-exact`), by expectedTf2Gaussian in double (lanes take the double body).
struct Gaussian2DKernel : Kernel2DBase, detail::ClassifyInLoad {
    const float* mean;
    const float* stddev;
    GradientGeometry gradientGeometry;
    const Tf2BlurTables* tables;  // null: the exact evaluation

    Gaussian2DKernel(const Grid3& grid, const float* m, const float* s,
                     const Tf2Raster<double>& exact, const Tf2Raster<float>& fast,
                     const MeanGradientView& meanGrad, const Tf2BlurTables* blur = nullptr)
        : Kernel2DBase(grid, exact, fast, meanGrad),
          mean(m),
          stddev(s),
          gradientGeometry(grid),
          tables(blur) {}
    /// The kernel over `m` for a row of the model table (model_rows.h) with a TF2: `s` (a
    /// Tf2Setup, model_families.h) holds the TF2's views and the gradients, and outlives it.
    template <class Setup>
    static Gaussian2DKernel make(const ModelView& m, Setup& s, const ClassifyOptions&,
                                 const ModelRow& row) {
        return Gaussian2DKernel(m.grid, m.mean.data(), m.stddev.data(), s.exact, s.fast,
                                s.meanGradientPlanes(), row.exactForm ? nullptr : s.blurTables());
    }
    /// (μ_X, μ_G, var X, cov(X, G), var G) at a scalar cell.
    UDVR_CPU_GPU void momentsAt(const Cell<double>& c, double m[5]) const {
        double n[3];
        m[1] = meanDirectionAt(c, true, n);  // n̂·μ_Y = |μ_Y|
        const GradientForm f = gradientFormAt(geometry, gradientGeometry, c);
        m[0] = m[2] = m[3] = m[4] = 0.0;
        for (int i = 0; i < f.count; ++i) {
            const double u = n[0] * f.coeff[i][0] + n[1] * f.coeff[i][1] + n[2] * f.coeff[i][2];
            const double s = stddev[f.voxel[i]], var = s * s;
            m[0] += f.w[i] * mean[f.voxel[i]];
            m[2] += f.w[i] * f.w[i] * var;
            m[3] += f.w[i] * u * var;
            m[4] += u * u * var;
        }
    }
    /// The moments over lanes (momentsAt's, in float), the 32-voxel form in closed form on every
    /// grid of at least 2 points an axis (else momentsAt per lane). Corner o's gradient along a
    /// is (X_hi − X_lo)·n̂_a/((hi − lo)·spacing_a) with lo, hi the neighbours of its point along
    /// a (GradientGeometry::stencil): inside the grid the outer voxel beyond o and the corner
    /// across a, k_a = n̂_a/(2·spacing_a) each; where o lies on the grid's first (o_a = 0, base
    /// index 0) or last (o_a = 1, base index dims − 2) point along a the difference is one-sided,
    /// o itself and the corner across, 2·k_a each, and there is no outer voxel. So corner o's u
    /// is Σ_a ±(the across corner's w times k_a, doubled where the across corner's difference
    /// is one-sided) ± (2·k_a·w_o where its own is), + where o_a = 1; the outer voxel beyond
    /// corner o along a has u = ±k_a·w_o; σ² gathered per voxel. (Before 2026-12-04 the lanes
    /// at a face took momentsAt per lane: ~9 % of the 64³ tangle's samples, 10 % of its gaussian
    /// frame.) Needs gathersFit(1).
    void momentsLanes(const Cell<lanes::Vf>& c, lanes::Mask live, lanes::Vf m[5]) const {
        using lanes::Vf, lanes::Vi;
        bool closedForm = true;
        for (int a = 0; a < 3; ++a) closedForm = closedForm && geometry.dims[a] >= 2;
        if (closedForm && lanes::anyOf(live)) {
            Vi idx[3];
            baseIndices(c, live, idx);
            lanes::Mask low[3], high[3];  // o's point is the grid's first / last along a
            for (int a = 0; a < 3; ++a) {
                low[a] = idx[a] <= 0;
                high[a] = idx[a] >= geometry.dims[a] - 2;
            }
            Vf n[3];
            m[1] = meanDirectionAt(c, live, n);
            m[0] = trilinear(geometry, mean, 1, c, live);
            const Vf one = lanes::splat<Vf>(1.0f), two = lanes::splat<Vf>(2.0f);
            const Vf f[3][2] = {{one - c.fx, c.fx}, {one - c.fy, c.fy}, {one - c.fz, c.fz}};
            Vf kk[3], kLow[3], kHigh[3];  // k_a, doubled where one-sided at the low / high point
            for (int a = 0; a < 3; ++a) {
                kk[a] = n[a] * static_cast<float>(0.5 * gradientGeometry.invSpacing[a]);
                kLow[a] = lanes::select(low[a], two * kk[a], kk[a]);
                kHigh[a] = lanes::select(high[a], two * kk[a], kk[a]);
            }
            Vf w[8];
            for (int o = 0; o < 8; ++o) w[o] = f[0][o & 1] * f[1][(o >> 1) & 1] * f[2][o >> 2];
            Vf vxx{}, vxg{}, vgg{};
            for (int o = 0; o < 8; ++o) {
                int off = 0;
                for (int a = 0; a < 3; ++a)
                    if ((o >> a) & 1) off += geometry.stride32[a];
                const Vi at = c.base + off;
                const Vf s = lanes::gather(stddev, at, live), var = s * s;
                Vf u{};
                for (int a = 0; a < 3; ++a) {
                    const Vf across = w[o ^ (1 << a)];
                    if ((o >> a) & 1) {  // o is the across corner's hi (its lo: outer, or itself
                                         // where low); o's own lo is the across corner
                        u = lanes::fma(kLow[a], across, u);
                        u = u + lanes::select(high[a], two * kk[a] * w[o], Vf{});
                    } else {  // o is the across corner's lo; o's own hi is the across corner
                        u = u - kHigh[a] * across;
                        u = u - lanes::select(low[a], two * kk[a] * w[o], Vf{});
                    }
                }
                vxx = lanes::fma(w[o] * w[o], var, vxx);
                vxg = lanes::fma(w[o] * u, var, vxg);
                vgg = lanes::fma(u * u, var, vgg);
                for (int a = 0; a < 3; ++a) {  // the outer voxel beyond corner o along a
                    const bool up = (o >> a) & 1;
                    const lanes::Mask has = live & !(up ? high[a] : low[a]);
                    const Vf so = lanes::gather(
                        stddev, at + (up ? geometry.stride32[a] : -geometry.stride32[a]), has);
                    const Vf uo = kk[a] * w[o];
                    vgg = lanes::fma(uo * uo, so * so, vgg);
                }
            }
            m[2] = vxx;
            m[3] = vxg;
            m[4] = vgg;
            return;
        }
        for (std::uint32_t b = lanes::bits(live); b; b &= b - 1) {
            const int l = std::countr_zero(b);
            double md[5];
            momentsAt(laneCell(c, l), md);
            for (int q = 0; q < 5; ++q) m[q][l] = static_cast<float>(md[q]);
        }
    }
    /// Its distribution at a cell: the bivariate normal of the 32-voxel form, handed to use(d).
    template <class T, class Use>
    UDVR_CPU_GPU UDVR_INLINE void reconstruct(const Cell<T>& c, lanes::MaskOf<T> live,
                                              const Use& use) const {
        T m[5] = {};
        if constexpr (lanes::kIsVector<T>) {
            momentsLanes(c, live, m);
        } else if constexpr (std::is_same_v<T, double>) {
            momentsAt(c, m);
        } else {
            double md[5];
            momentsAt(Cell<double>{c.base, c.fx, c.fy, c.fz}, md);
            for (int k = 0; k < 5; ++k) m[k] = static_cast<T>(md[k]);
        }
        use(JointNormal<T>{m[0], m[1], m[2], m[3], m[4], &tfExact, tables});
    }
    template <class T>
    UDVR_CPU_GPU UDVR_INLINE Classified<T> load(const Cell<T>& c, lanes::MaskOf<T> live) const {
        Classified<T> r{};
        if constexpr (lanes::kIsVector<T>) {
            // gaussian-exact (the reference) and batches past int32 gathers: the double body.
            if (!tables || !gathersFit(1)) {
                detail::exactWhere(*this, c, live, r.v);
                return r;
            }
        }
        detail::classify2DOver<T>(*this, c, live, r.v);
        return r;
    }
    void voxelSupport(std::size_t voxel, float& lo, float& hi) const {
        const double s = kSupportSigmas * static_cast<double>(stddev[voxel]);
        lo = static_cast<float>(mean[voxel] - s);
        hi = static_cast<float>(mean[voxel] + s);
    }
    void prefetch(int) const {}
};

namespace detail {
/// A voxel of the 32-voxel gradient form at a cell whose 8 corners have weight and whose grid
/// gradients are all central differences: corner `corner` (axis −1) or the voxel beyond corner
/// `corner` along `axis`.
struct FormVoxel {
    int corner = 0, axis = -1;
};
/// Those 32 voxels in gradientFormAt's slot order (each corner, then its stencil's upper and
/// lower neighbour per axis), so sums over them take the scalar body's order.
constexpr std::array<FormVoxel, 32> interiorFormVoxels() {
    std::array<FormVoxel, 32> v{};
    int count = 0;
    const auto slot = [&](int corner, int axis) {
        for (int s = 0; s < count; ++s)
            if (v[s].corner == corner && v[s].axis == axis) return;
        v[count++] = {corner, axis};
    };
    for (int o = 0; o < 8; ++o) {
        slot(o, -1);
        for (int a = 0; a < 3; ++a) {
            const int bit = 1 << a;
            if (o & bit) {
                slot(o, a);         // upper neighbour: beyond the cell
                slot(o ^ bit, -1);  // lower: the corner across
            } else {
                slot(o | bit, -1);
                slot(o, a);
            }
        }
    }
    return v;
}
inline constexpr std::array<FormVoxel, 32> kInteriorFormVoxels = interiorFormVoxels();
}  // namespace detail

/// Uniform with a TF2 (SPEC §9): independent uniform voxels X_i ~ U[lo_i, hi_i] (μ ± √3σ, or
/// [min, max] with `--uniform-width minmax`); (X, G) = Σ_i (w_i, u_i) X_i over the 32-voxel form
/// is the paper's bivariate box spline (JointBoxSpline, distributions_2d.h), reconstructed once
/// per sample over the lane type (`reconstruct`; its values in double on every T). E[TF2] per
/// lane in double: `uniform-exact` by expectedTf2UniformExact converged (≤ 1e−6); `uniform`
/// (and its alias `uniform-fast`) by columns (Tf2BlurTables::boxSpline, expected_tf2_fast.h: per
/// x basis function the law of G given X to κ6 (Gram–Charlier), dominant corners cut into pieces,
/// over the y-blurred tables; max 2.0e−4 off uniform-exact at 150 random points of the 64³
/// tangle, 9.8e−4 on 2000 rough random TF2s, 1.6e−6 tooth, docs/models.md), or with fewer than 8
/// corners or without tables by expectedTf2UniformRefined (the coarser kUniform2DFast settings,
/// refined where they miss).
struct Uniform2DKernel : Kernel2DBase, UniformVoxels, detail::ClassifyInLoad {
    bool exact;        // `uniform-exact` (expectedTf2UniformExact), else the fast form
    double tinyWidth;  // data units: directions this narrow in X count for G only (exact)
    GradientGeometry gradientGeometry;
    const Tf2BlurTables* tables;  // the fast form's tables (null: expectedTf2UniformRefined)

    /// The kernel over `m` for a row of the model table (model_rows.h) with a TF2: `s` (a
    /// Tf2Setup, model_families.h) holds the TF2's views and the gradients, and outlives it.
    /// (An aggregate: its bases, then its members in declaration order.)
    template <class Setup>
    static Uniform2DKernel make(const ModelView& m, Setup& s, const ClassifyOptions& o,
                                const ModelRow& row) {
        const bool minMax = o.uniformMinMax;
        return {Kernel2DBase(m.grid, s.exact, s.fast, s.meanGradientPlanes()),
                UniformVoxels{minMax ? m.min.data() : m.mean.data(),
                              minMax ? m.max.data() : m.stddev.data(), minMax},
                {},
                row.exactForm,
                kUniformTinyWidth * dataSpan(m, o),
                GradientGeometry(m.grid),
                row.exactForm ? nullptr : s.blurTables()};
    }
    /// The centre (X, G at t = 0) and the directions at a scalar cell; returns their count.
    /// `corners` (where given): how many voxels have a trilinear weight > 0 (8 inside a cell;
    /// fewer on its faces, edges and grid points).
    UDVR_CPU_GPU int directionsAt(const Cell<double>& c, double& cx, double& cy,
                                  BoxDirection2 d[32], int* corners = nullptr) const {
        double n[3];
        meanDirectionAt(c, true, n);
        const GradientForm f = gradientFormAt(geometry, gradientGeometry, c);
        cx = cy = 0.0;
        for (int i = 0; i < f.count; ++i) {
            const double u = n[0] * f.coeff[i][0] + n[1] * f.coeff[i][1] + n[2] * f.coeff[i][2];
            double lo, hi;
            interval(f.voxel[i], lo, hi);
            const double mid = 0.5 * (lo + hi), h = 0.5 * (hi - lo);
            cx += f.w[i] * mid;
            cy += u * mid;
            d[i] = {f.w[i] * h, u * h};
        }
        if (corners) {
            *corners = 0;
            for (int i = 0; i < f.count; ++i) *corners += f.w[i] > 0.0;
        }
        return f.count;
    }
    /// directionsAt into lane l of s (or into s on a scalar T).
    template <class T>
    UDVR_CPU_GPU void directionsInto(const Cell<double>& c, JointBoxSpline<T>& s, int l) const {
        double cx, cy;
        BoxDirection2 d[32];
        int corners = 0;
        const int n = directionsAt(c, cx, cy, d, &corners);
        if constexpr (lanes::kIsVector<T>) {
            s.cx[l] = cx;
            s.cg[l] = cy;
            for (int i = 0; i < n; ++i) {
                s.a[i][l] = d[i].a;
                s.b[i][l] = d[i].b;
            }
            s.count[l] = n;
            s.allCorners[l] = corners == 8 ? -1 : 0;
        } else {
            s.cx = cx;
            s.cg = cy;
            for (int i = 0; i < n; ++i) {
                s.a[i] = d[i].a;
                s.b[i] = d[i].b;
            }
            s.count = n;
            s.allCorners = corners == 8;
        }
    }
    /// directionsAt over lanes, the values in double lanes: the lanes whose 8 corners have weight
    /// and whose 32 voxels have central differences (interiorLanes) in closed form — corner o's
    /// gradient coefficient along axis a is ±w of the corner across a times 1/(2·spacing_a) (+
    /// where o_a = 1), the voxel beyond corner o along a has ±w_o/(2·spacing_a) there — in
    /// directionsAt's order and arithmetic, so each lane's values are its scalar body's
    /// (Uniform2D.LaneBoxSplineIsTheDoubleOnePerLane); the rest take directionsAt per lane.
    /// Needs gathersFit(1).
    void directionsLanes(const Cell<lanes::Vf>& c, lanes::Mask live,
                         JointBoxSpline<lanes::Vf>& s) const {
        using Vd = JointBoxSpline<lanes::Vf>::Wide;
        using lanes::Vf, lanes::Vi;
        const lanes::Mask fast = interiorLanes(c, live) & (c.fx > 0.0f) & (c.fx < 1.0f) &
                                 (c.fy > 0.0f) & (c.fy < 1.0f) & (c.fz > 0.0f) & (c.fz < 1.0f);
        if (lanes::anyOf(fast)) {
            const Vd one = lanes::splat<Vd>(1.0);
            const Vd fx = __builtin_convertvector(c.fx, Vd), fy = __builtin_convertvector(c.fy, Vd),
                     fz = __builtin_convertvector(c.fz, Vd);
            Vd w[8];  // trilinearWeights' product
            for (int k = 0; k < 8; ++k)
                w[k] = ((k & 1) ? fx : one - fx) * ((k & 2) ? fy : one - fy) *
                       ((k & 4) ? fz : one - fz);
            Vd n[3] = {};
            for (std::uint32_t b = lanes::bits(fast); b; b &= b - 1) {
                const int l = std::countr_zero(b);
                double nl[3];
                meanDirectionAt(laneCell(c, l), true, nl);
                for (int a = 0; a < 3; ++a) n[a][l] = nl[a];
            }
            double scale[3];  // gradientFormAt's stencil scale of a central difference
            for (int a = 0; a < 3; ++a) scale[a] = gradientGeometry.invSpacing[a] / 2;
            Vd cx{}, cy{};
            for (int i = 0; i < 32; ++i) {
                const detail::FormVoxel v = detail::kInteriorFormVoxels[i];
                int off = 0;
                for (int a = 0; a < 3; ++a)
                    if ((v.corner >> a) & 1) off += geometry.stride32[a];
                Vd wi{}, coeff[3] = {};
                if (v.axis < 0) {
                    wi = w[v.corner];
                    for (int a = 0; a < 3; ++a) {
                        const int bit = 1 << a;
                        coeff[a] = (v.corner & bit) ? w[v.corner ^ bit] * scale[a]
                                                    : -(w[v.corner | bit] * scale[a]);
                    }
                } else {
                    const bool up = (v.corner >> v.axis) & 1;
                    off += up ? geometry.stride32[v.axis] : -geometry.stride32[v.axis];
                    coeff[v.axis] =
                        up ? w[v.corner] * scale[v.axis] : -(w[v.corner] * scale[v.axis]);
                }
                const Vi at = c.base + off;
                const Vd p = __builtin_convertvector(lanes::gather(first, at, fast), Vd);
                const Vd q = __builtin_convertvector(lanes::gather(second, at, fast), Vd);
                Vd lo = p, hi = q;  // UniformVoxels::interval
                if (!minMax) {
                    const Vd h = 1.7320508075688772 * q;
                    lo = p - h;
                    hi = p + h;
                }
                const Vd u = n[0] * coeff[0] + n[1] * coeff[1] + n[2] * coeff[2];
                const Vd mid = 0.5 * (lo + hi), h = 0.5 * (hi - lo);
                cx += wi * mid;
                cy += u * mid;
                s.a[i] = wi * h;
                s.b[i] = u * h;
            }
            s.cx = cx;
            s.cg = cy;
            s.count = lanes::select(fast, lanes::splat<Vi>(32), s.count);
            s.allCorners = fast;
        }
        for (std::uint32_t b = lanes::bits(live & !fast); b; b &= b - 1) {
            const int l = std::countr_zero(b);
            directionsInto(laneCell(c, l), s, l);
        }
    }
    /// Its distribution at a cell: the bivariate box spline of the 32-voxel form
    /// (JointBoxSpline), handed to use(d).
    template <class T, class Use>
    UDVR_CPU_GPU UDVR_INLINE void reconstruct(const Cell<T>& c, lanes::MaskOf<T> live,
                                              const Use& use) const {
        JointBoxSpline<T> s;
        s.tinyWidth = tinyWidth;
        s.raster = &tfExact;
        s.tables = exact ? nullptr : tables;
        s.converged = exact;
        if constexpr (lanes::kIsVector<T>)
            directionsLanes(c, live, s);
        else
            directionsInto(Cell<double>{c.base, c.fx, c.fy, c.fz}, s, 0);
        use(s);
    }
    template <class T>
    UDVR_CPU_GPU UDVR_INLINE Classified<T> load(const Cell<T>& c, lanes::MaskOf<T> live) const {
        Classified<T> r{};
        if constexpr (lanes::kIsVector<T>) {
            if (!gathersFit(1)) {  // batches past int32 gathers: the double body
                detail::exactWhere(*this, c, live, r.v);
                return r;
            }
        }
        detail::classify2DOver<T>(*this, c, live, r.v);
        return r;
    }
    using UniformVoxels::voxelSupport;
    void prefetch(int) const {}
};

/// The quantile models with a TF2 through the rank coupling of SPEC §9: boundaries j0 … j1 of
/// an array with `stride` floats per voxel give the polyline (X_j, G_j), X_j = Σ w_c b_{j,c},
/// G_j = n̂·Y_j. quantile-range (and the quartile views, iqr): Σ_j mean of TF2 along segment j
/// / (j1 − j0); quantile-mean(-mass): TF2 at the segment midpoints with Eq. 5's weights.
struct Quantile2DKernel : Kernel2DBase, detail::ClassifyInLoad {
    const float* boundaries;
    int stride;                      // floats per voxel of `boundaries`
    int j0, j1;                      // boundaries j0 … j1 (j1 − j0 + 1 ≤ kMaxBoundaries2D)
    const float* boundaryGradients;  // the mean's, then boundaries j0 … j1's: VoxelRows
    QuantileLevels levels;           // of boundaries j0 …
    bool quantileMean;               // Eq. 5 at midpoints (else Eq. 4 along segments)
    bool densityWeights;             // quantile-mean: 1/w_j weights (else equal)
    double zeroWidth;                // quantile-mean: widths at or below are point masses

    /// The kernel over `m` for a row of the model table (model_rows.h) with a TF2: `s` (a
    /// Tf2Setup, model_families.h) holds the TF2's views and the gradients, and outlives it.
    /// The iqr array's two boundaries, the row's population of the quantiles (Eq. 4), or all
    /// of them at their midpoints (Eq. 5, the quantile-mean rows). (An aggregate: its bases,
    /// then its members in declaration order; the mean's gradients lead `gradients`' rows.)
    template <class Setup>
    static Quantile2DKernel make(const ModelView& m, Setup& s, const ClassifyOptions& o,
                                 const ModelRow& row) {
        const auto [data, stride, lo, hi, levels, densityWeights, zeroWidth] =
            quantileBoundariesOf(m, row, o);
        const bool quantileMean = row.quantileMeanWeights != QuantileMeanWeights::None;
        if (hi - lo + 1 > kMaxBoundaries2D)
            UDVR_FAIL("2D transfer functions handle at most "
                      << kMaxBoundaries2D - 1 << " quantiles, the model has " << hi - lo);
        const float* gradients =
            s.gradients
                .of(m.grid, data, stride, lo, hi - lo + 1, GradientLayout::VoxelRows, m.mean.data())
                .data();
        const int rows = hi - lo + 2;
        return {Kernel2DBase(m.grid, s.exact, s.fast,
                             {gradients, 3 * rows, static_cast<std::size_t>(rows)}),
                {},
                data,
                stride,
                lo,
                hi,
                gradients,
                QuantileLevels{levels, lo},
                quantileMean,
                densityWeights,
                zeroWidth};
    }

    /// The polyline's vertices X[0 … count−1], G[…] at a cell, X_j = boundary(j); returns count.
    /// The gradients (the mean's, for n̂, and the boundaries') are blended from one VoxelRows
    /// array; on lanes, up to kMaxGradientRows components come from the batch's transposed rows
    /// (boundaryRows: 30 floats per corner for q = 8 in two or four loads, against 30 trilinear
    /// blends of 4 pair gathers each).
    template <class T, class Boundary>
    UDVR_CPU_GPU UDVR_INLINE int polylineAt(const Cell<T>& c, lanes::MaskOf<T> live,
                                            const Boundary& boundary, T* x, T* g) const {
        const int count = j1 - j0 + 1, layers = count + 1;  // layer 0: the mean
        const int rowLength = 3 * layers;
        const auto polyline = [&](const auto& component) {
            T n[3];
            const T y[3] = {component(0), component(layers), component(2 * layers)};
            directionOf(y, n);
            for (int j = 0; j < count; ++j) {
                x[j] = boundary(j);
                T gj{};
                for (int a = 0; a < 3; ++a)
                    gj = lanes::fma(n[a], component(a * layers + 1 + j), gj);
                g[j] = gj;
            }
        };
        if constexpr (lanes::kIsVector<T>) {
            if (rowLength <= kMaxGradientRows) {
                lanes::Vf rows[kMaxGradientRows];
                boundaryRows(geometry, boundaryGradients, rowLength, 0, rowLength, c, live, rows);
                polyline([&](int i) { return rows[i]; });
                return count;
            }
        }
        polyline(
            [&](int i) { return trilinear(geometry, boundaryGradients + i, rowLength, c, live); });
        return count;
    }
    /// Its distribution from the boundaries at the sample (boundary(j), j < j1 − j0 + 1) and the
    /// quantiles' X-widths (width(j), for Eq. 5's density weights), handed to use(d): the
    /// polyline's segments (QuantilePolyline, Eq. 4: quantile-range, iqr, the quartile views) or
    /// their midpoints (PolylineMidpoints, Eq. 5: quantile-mean(-mass)).
    template <class T, class Boundary, class Width, class Use>
    UDVR_CPU_GPU UDVR_INLINE void reconstructFrom(const Cell<T>& c, lanes::MaskOf<T> live,
                                                  const Boundary& boundary, const Width& width,
                                                  const Use& use) const {
        T x[kMaxBoundaries2D], g[kMaxBoundaries2D];
        const int count = polylineAt(c, live, boundary, x, g);
        if (!quantileMean)
            use(QuantilePolyline<T>{x, g, count, levels});
        else
            use(PolylineMidpoints<T, Width>{
                {x, g, count, levels}, width, densityWeights, zeroWidth});
    }
    /// reconstructFrom with each boundary and width blended on its own (Eq. 2).
    template <class T, class Use>
    UDVR_CPU_GPU UDVR_INLINE void reconstruct(const Cell<T>& c, lanes::MaskOf<T> live,
                                              const Use& use) const {
        reconstructFrom(
            c, live,
            [&](int j) UDVR_INLINE_LAMBDA {
                return boundaryAt<T>(geometry, boundaries, stride, j0 + j, c, live);
            },
            [&](int j) UDVR_INLINE_LAMBDA {
                return widthAt<T>(geometry, boundaries, stride, j0 + j, c, live);
            },
            use);
    }
    template <class T>
    UDVR_CPU_GPU UDVR_INLINE Classified<T> load(const Cell<T>& c, lanes::MaskOf<T> live) const {
        Classified<T> r;
        const auto classify = [&](const auto& d)
                                  UDVR_INLINE_LAMBDA { expectedTf2(tf2<T>(), d, live, r.v); };
        if constexpr (lanes::kIsVector<T>) {
            const int count = j1 - j0 + 1;
            if (!gathersFit(stride) || !gathersFit(3 * (count + 1))) {
                detail::exactLanes(*this, c, live, r.v);
                return r;
            }
            if (count <= kMaxRowBoundaries) {  // boundaries and widths by the batch's rows
                // (widths only for Eq. 5's density weights, as the 1D kernel: quantile-mean-mass,
                // 1D TF as TF2, 463-470 → 427-431 ms)
                lanes::Vf b[kMaxRowBoundaries], w[kMaxRowBoundaries];
                boundaryRows(geometry, boundaries, stride, j0, count, c, live, b,
                             quantileMean && densityWeights ? w : nullptr);
                // Samples whose values all lie in columns with α = 0 are 0: no gradient rows
                // (512² tangle, one thread: 1D TF as TF2 679-681 → 654-676 ms; the widget
                // TF2 at 256², 2022-2058 → 1983 ms).
                live = live & !tf2ColumnsEmpty<T>(tf2<T>(), b[0], b[count - 1], live);
                if (!lanes::anyOf(live)) return Classified<T>{};
                reconstructFrom(
                    c, live, [&](int j) UDVR_INLINE_LAMBDA { return b[j]; },
                    [&](int j) UDVR_INLINE_LAMBDA { return w[j]; }, classify);
                detail::keepLive<T>(live, r.v);
                return r;
            }
        }
        detail::classify2DOver<T>(*this, c, live, r.v);
        return r;
    }
    void voxelSupport(std::size_t voxel, float& lo, float& hi) const {
        const float* b = boundaries + voxel * static_cast<std::size_t>(stride);
        lo = b[j0];
        hi = b[j1];
    }
    void prefetch(int v) const {
        prefetchRows(boundaries + j0, v, stride);
        prefetchRows(boundaryGradients, v, 3 * (j1 - j0 + 2));
    }
};

}  // namespace udvr
