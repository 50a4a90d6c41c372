#pragma once
// 2D transfer functions (SPEC §9) on a raster: colour and α each bilinear between the points and
// clamped outside the domain; lookups (tf2At) and the empty-column test. Each body is written
// once over T ∈ {double, float, lanes::Vf} as expected_tf.h; lanes read the raster by gathers,
// or two adjacent points at once by per-lane loads (lanes::gatherRow8).
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include "udvr/reconstruct/quantile_interp.h"
#include "udvr/util/lanes.h"

namespace udvr {

/// Read-only view of a raster TF2 (classify/transfer_function_2d.h) with coordinates over Real;
/// device-copyable. Points: rgba[(j·width + i)·4 + ch], (r, g, b, α).
template <class Real>
struct Tf2Raster {
    int width = 2, height = 2;
    Real x0 = 0, y0 = 0;        // domain origin
    Real invDx = 1, invDy = 1;  // raster cells per data unit along x and y
    const float* rgba = nullptr;
    /// Optional, per cell (j·(width − 1) + i): 0 where a corner has α > 0, else the Chebyshev
    /// distance d ≥ 1 (in cells) to the nearest such cell — every cell closer than d has α = 0
    /// (TransferFunction2D::emptyCellDistances). Segment means skip those cells and jump over
    /// the block of them.
    const float* cellEmptyDistance = nullptr;
    /// Optional, per cell (2 floats at 2·(j·(width − 1) + i)): the run [lo, hi) of point
    /// columns containing it over which the band is bilinear
    /// (TransferFunction2D::linearCellRuns). Segment means then take one piece per run, not
    /// per cell; without it every cell is its own run.
    const float* cellRun = nullptr;
    /// Optional, both or neither: per row j, the last row j' ≥ j identical to it
    /// (TransferFunction2D::identicalRowsUpTo); per point, 8 floats: row j's prefix integrals of
    /// (α·r, α·g, α·b, α) over x, hi then lo (TransferFunction2D::rowPrefixIntegrals). A
    /// segment whose y range sees one row's function only then takes its mean in O(1)
    /// (detail::rowConstantMean), not by a walk.
    const float* rowSameUpTo = nullptr;
    const float* rowPrefix = nullptr;
    /// Optional, per column of cells i (width − 1 floats): how many columns of cells from i on
    /// have α = 0 at every corner of every row (0 where column i has a cell with α > 0). Over
    /// such columns TF2(x, ·) = 0 whatever y, so the quantile kernels skip the gradients of
    /// samples whose boundaries all lie there (tf2ColumnsEmpty).
    const float* columnEmptyRun = nullptr;
    /// Optional, per raster point (j·width + i): how many cells with α > 0 at a corner lie in
    /// columns < i and rows < j (a summed-area table over TransferFunction2D::cellOpaque), so
    /// that a box of cells has none in four reads: segments whose box of cells has none add 0
    /// to a mean and are not walked (tf2SegmentCellsEmpty).
    const float* cellOpaqueSum = nullptr;
    /// Optional: the banded walk's prefix tables, kTf2BandMoments doubles per record
    /// (TransferFunction2D::bandPrefixMoments; read by detail::bandRunSum). With them a
    /// segment walks the raster lines of the axis it crosses fewer of, and takes the cells it
    /// crosses along the other axis from the tables (detail::bandedWalk), exactly; cellRun is
    /// then not used.
    const double* bandPrefix = nullptr;
    /// Optional with bandPrefix: per band of cells (those between x lines, then those between y
    /// lines), the first cell along it with α > 0 at a corner and one past the last, as floats
    /// (first ≥ last: none); the walk reads no records outside.
    const float* bandCells = nullptr;
    /// The box of raster coordinates [s0, s1] × [t0, t1] outside which α = 0 (±inf where cells
    /// with α > 0 reach the domain's edge, the TF2 clamped beyond it; s0 > s1 where α = 0
    /// everywhere; the default: everywhere). The banded walk walks only the part of a segment
    /// inside; the pooled cell walk (PooledPolylineSegments) trims its segments to it.
    Real opaqueBox[4] = {
        -std::numeric_limits<Real>::infinity(), std::numeric_limits<Real>::infinity(),
        -std::numeric_limits<Real>::infinity(), std::numeric_limits<Real>::infinity()};
};

/// The summed-area table of a width × height raster's cells with α > 0 at a corner (rgba as
/// Tf2Raster's): entry j·width + i counts those cells in columns < i and rows < j (row 0 and
/// column 0 hold 0), so a box of cells has none in four reads (Tf2Raster::cellOpaqueSum, the
/// fast gaussian's transparent test). T: float (exact up to 2^24 cells) or an integer type.
template <class T>
void opaqueCellSums(const float* rgba, int width, int height, std::vector<T>& sums) {
    const auto alpha = [&](int i, int j) {
        return rgba[(static_cast<std::size_t>(j) * width + i) * 4 + 3];
    };
    sums.assign(static_cast<std::size_t>(width) * height, T{});
    for (int j = 0; j + 1 < height; ++j)
        for (int i = 0; i + 1 < width; ++i) {
            const bool opaque = alpha(i, j) > 0.f || alpha(i + 1, j) > 0.f ||
                                alpha(i, j + 1) > 0.f || alpha(i + 1, j + 1) > 0.f;
            const std::size_t k = static_cast<std::size_t>(j + 1) * width + (i + 1);
            sums[k] = static_cast<T>(opaque ? 1 : 0) + sums[k - 1] + sums[k - width] -
                      sums[k - width - 1];
        }
}

/// Doubles per record of Tf2Raster::bandPrefix: α's 3 moments, then 6 per colour channel.
inline constexpr int kTf2BandMoments = 21;

namespace detail {
/// Raster index coordinate of v (cells from the origin), clamped to [0, n − 1]; NaN → 0.
template <class T>
UDVR_CPU_GPU UDVR_INLINE T rasterCoordinate(T v, lanes::ScalarOf<T> origin, lanes::ScalarOf<T> inv,
                                            int n) {
    using S = lanes::ScalarOf<T>;
    const T s = (v - origin) * inv;
    return lanes::select(s > S(0), lanes::min(s, lanes::splat<T>(S(n - 1))), T{});
}
/// Cell index (≤ n − 2) and fraction of a clamped raster coordinate.
template <class T>
UDVR_CPU_GPU UDVR_INLINE void rasterCell(T s, int n, lanes::IntOf<T>& i, T& f) {
    if constexpr (lanes::kIsVector<T>) {
        i = lanes::min(lanes::truncToInt(s), lanes::splati(n - 2));
        f = s - lanes::toFloat(i);
    } else {
        i = static_cast<int>(s);
        i = i < n - 2 ? i : n - 2;
        f = s - static_cast<T>(i);
    }
}
/// rgba[idx + ch] per lane (live lanes only) or for a scalar index.
template <class T>
UDVR_CPU_GPU UDVR_INLINE T rasterLoad(const float* rgba, lanes::IntOf<T> idx,
                                      lanes::MaskOf<T> live) {
    if constexpr (lanes::kIsVector<T>)
        return lanes::gather(rgba, idx, live);
    else
        return static_cast<T>(rgba[idx]);
}
/// Two raster points (r, g, b, α) side by side at rgba[base …], into p0 and p1 (lanes of
/// `live`; 0 in the others).
template <class T>
UDVR_CPU_GPU UDVR_INLINE void rasterPoints2(const float* rgba, lanes::IntOf<T> base,
                                            lanes::MaskOf<T> live, T p0[4], T p1[4]) {
    if constexpr (lanes::kIsVector<T>) {
        T v[8];
        lanes::gatherRow8(rgba, base, live, v);
        for (int ch = 0; ch < 4; ++ch) {
            p0[ch] = v[ch];
            p1[ch] = v[4 + ch];
        }
    } else {
        for (int ch = 0; ch < 4; ++ch) {
            p0[ch] = live ? static_cast<T>(rgba[base + ch]) : T{};
            p1[ch] = live ? static_cast<T>(rgba[base + 4 + ch]) : T{};
        }
    }
}
/// (r, g, b, α) of the raster point at rgba[base …] (lanes of `live`; 0 in the others).
template <class T>
UDVR_CPU_GPU UDVR_INLINE void rasterPoint(const float* rgba, lanes::IntOf<T> base,
                                          lanes::MaskOf<T> live, T out[4]) {
    if constexpr (lanes::kIsVector<T>) {  // (r, g) and (b, α): one 64-bit load each
        lanes::gatherPair(rgba, base, live, out[0], out[1]);
        lanes::gatherPair(rgba, base + 2, live, out[2], out[3]);
    } else {
        for (int ch = 0; ch < 4; ++ch) out[ch] = live ? static_cast<T>(rgba[base + ch]) : T{};
    }
}
}  // namespace detail

/// The 4 corners × (r, g, b, α) of raster cell (i, j), loaded once and evaluated at any point of
/// the cell (colour and α each bilinear).
template <class T>
struct Tf2Cell {
    T v[4][4];  // [corner: (i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)][channel]

    template <class Real>
    UDVR_CPU_GPU UDVR_INLINE Tf2Cell(const Tf2Raster<Real>& r, lanes::IntOf<T> i, lanes::IntOf<T> j,
                                     lanes::MaskOf<T> live) {
        const lanes::IntOf<T> row = j * r.width + i;  // points i, i + 1: 8 adjacent floats
        detail::rasterPoints2<T>(r.rgba, row * 4, live, v[0], v[1]);
        detail::rasterPoints2<T>(r.rgba, (row + r.width) * 4, live, v[2], v[3]);
    }
    /// The cell spanning point columns i0 < i1 (a run of cells, see Tf2Raster::cellRun) of
    /// band j; `at` then takes fx as the fraction of [i0, i1].
    template <class Real>
    UDVR_CPU_GPU UDVR_INLINE Tf2Cell(const Tf2Raster<Real>& r, lanes::IntOf<T> i0,
                                     lanes::IntOf<T> i1, lanes::IntOf<T> j, lanes::MaskOf<T> live) {
        const lanes::IntOf<T> row = j * r.width, up = row + r.width;
        const lanes::IntOf<T> base[4] = {(row + i0) * 4, (row + i1) * 4, (up + i0) * 4,
                                         (up + i1) * 4};
        for (int k = 0; k < 4; ++k) detail::rasterPoint<T>(r.rgba, base[k], live, v[k]);
    }
    /// (c_r, c_g, c_b, α) at fractions (fx, fy) of the cell.
    UDVR_CPU_GPU UDVR_INLINE void at(T fx, T fy, T out[4]) const {
        for (int ch = 0; ch < 4; ++ch) {
            const T lo = lanes::fma(fx, v[1][ch] - v[0][ch], v[0][ch]);
            const T hi = lanes::fma(fx, v[3][ch] - v[2][ch], v[2][ch]);
            out[ch] = lanes::fma(fy, hi - lo, lo);
        }
    }
};

/// Colour and α of the TF2 at raster coordinates (s, t) (clamped, see rasterCoordinate):
/// out = (c_r, c_g, c_b, α), each bilinear.
template <class T, class Real>
UDVR_CPU_GPU UDVR_INLINE void tf2ColorOpacityAtRaster(const Tf2Raster<Real>& r, T s, T t,
                                                      lanes::MaskOf<T> live, T out[4]) {
    lanes::IntOf<T> i, j;
    T fx, fy;
    detail::rasterCell(s, r.width, i, fx);
    detail::rasterCell(t, r.height, j, fy);
    Tf2Cell<T>(r, i, j, live).at(fx, fy, out);
}

/// TF2(x, y) premultiplied: (α·r, α·g, α·b, α). Dead lanes read nothing (their result is junk).
template <class T, class Real>
UDVR_CPU_GPU UDVR_INLINE void tf2At(const Tf2Raster<Real>& r, T x, T y, lanes::MaskOf<T> live,
                                    T out[4]) {
    using S = lanes::ScalarOf<T>;
    const T s =
        detail::rasterCoordinate<T>(x, static_cast<S>(r.x0), static_cast<S>(r.invDx), r.width);
    const T t =
        detail::rasterCoordinate<T>(y, static_cast<S>(r.y0), static_cast<S>(r.invDy), r.height);
    lanes::IntOf<T> i, j;
    T fx, fy;
    detail::rasterCell(s, r.width, i, fx);
    detail::rasterCell(t, r.height, j, fy);
    auto load = live;
    if constexpr (lanes::kIsVector<T>) {
        // Lanes in cells whose four corners have α = 0 are 0: one gather of the cells' empty
        // distances instead of eight pair gathers where no lane sees α (the 1D tangle TF as a
        // TF2, quantile-mean's midpoints, 64³ 512²: 204 → 192 ms).
        if (r.cellEmptyDistance) {
            load = live & (detail::rasterLoad<T>(r.cellEmptyDistance, j * (r.width - 1) + i,
                                                 live) == 0.0f);
            if (!lanes::anyOf(load)) {
                for (int ch = 0; ch < 4; ++ch) out[ch] = T{};
                return;
            }
        }
    }
    T v[4];
    Tf2Cell<T>(r, i, j, load).at(fx, fy, v);  // lanes outside `load`: corners 0, α = 0
    for (int ch = 0; ch < 3; ++ch) out[ch] = v[3] * v[ch];
    out[3] = v[3];
}

/// Lanes of `live` whose segment from (xa, ya) to (xb, yb) (finite ends) lies in a box of cells
/// with α = 0 at every corner (Tf2Raster::cellOpaqueSum): the cells of its clamped ends' box,
/// which hold every cell a walk of it reads, so its mean is 0 exactly. None without the table.
template <class T, class Real>
UDVR_CPU_GPU UDVR_INLINE lanes::MaskOf<T> tf2SegmentCellsEmpty(const Tf2Raster<Real>& r, T xa, T ya,
                                                               T xb, T yb, lanes::MaskOf<T> live) {
    using S = lanes::ScalarOf<T>;
    using I = lanes::IntOf<T>;
    if (!r.cellOpaqueSum) return lanes::MaskOf<T>{};
    const S x0 = static_cast<S>(r.x0), ix = static_cast<S>(r.invDx);
    const S y0 = static_cast<S>(r.y0), iy = static_cast<S>(r.invDy);
    I i0, i1, j0, j1;
    T f;
    detail::rasterCell(detail::rasterCoordinate<T>(lanes::min(xa, xb), x0, ix, r.width), r.width,
                       i0, f);
    detail::rasterCell(detail::rasterCoordinate<T>(lanes::max(xa, xb), x0, ix, r.width), r.width,
                       i1, f);
    detail::rasterCell(detail::rasterCoordinate<T>(lanes::min(ya, yb), y0, iy, r.height), r.height,
                       j0, f);
    detail::rasterCell(detail::rasterCoordinate<T>(lanes::max(ya, yb), y0, iy, r.height), r.height,
                       j1, f);
    constexpr S kMax = std::numeric_limits<S>::max();
    // Named masks: `&` of bools over calls is what clang's -Wbitwise-instead-of-logical flags.
    const auto finiteXa = lanes::abs(xa) <= kMax, finiteXb = lanes::abs(xb) <= kMax;
    const auto finiteYa = lanes::abs(ya) <= kMax, finiteYb = lanes::abs(yb) <= kMax;
    const lanes::MaskOf<T> m = live & finiteXa & finiteXb & finiteYa & finiteYb;
    const I lo = j0 * r.width, hi = (j1 + 1) * r.width;
    const T inside = detail::rasterLoad<T>(r.cellOpaqueSum, hi + i1 + 1, m) -
                     detail::rasterLoad<T>(r.cellOpaqueSum, lo + i1 + 1, m) -
                     detail::rasterLoad<T>(r.cellOpaqueSum, hi + i0, m) +
                     detail::rasterLoad<T>(r.cellOpaqueSum, lo + i0, m);
    return m & (inside == S(0));
}

/// Lanes of `live` whose values x ∈ [xa, xb] (xa ≤ xb) lie in columns of cells with α = 0 in
/// every row (Tf2Raster::columnEmptyRun): the TF2 is 0 there for every y, and so is its mean
/// along any segment or at any point within [xa, xb]. The columns are those tf2At reads
/// (x clamped into the domain, NaN → the first column). None without the table.
template <class T, class Real>
UDVR_CPU_GPU UDVR_INLINE lanes::MaskOf<T> tf2ColumnsEmpty(const Tf2Raster<Real>& r, T xa, T xb,
                                                          lanes::MaskOf<T> live) {
    using S = lanes::ScalarOf<T>;
    if (!r.columnEmptyRun) return lanes::MaskOf<T>{};
    const S x0 = static_cast<S>(r.x0), inv = static_cast<S>(r.invDx);
    lanes::IntOf<T> ia, ib;
    T f;
    detail::rasterCell(detail::rasterCoordinate<T>(xa, x0, inv, r.width), r.width, ia, f);
    detail::rasterCell(detail::rasterCoordinate<T>(xb, x0, inv, r.width), r.width, ib, f);
    const T run = detail::rasterLoad<T>(r.columnEmptyRun, ia, live);
    if constexpr (lanes::kIsVector<T>)
        return live & (ib >= ia) & (run > lanes::toFloat(ib - ia));
    else
        return live && ib >= ia && run > static_cast<T>(ib - ia);
}

}  // namespace udvr
