#pragma once
// Classification with 2D transfer functions (SPEC §9): TF2 on a raster, colour and α each
// bilinear between the points and clamped outside the domain. Each body is written once over
// T ∈ {double, float, lanes::Vf} as expected_tf.h; lanes read the raster by gathers, or two
// adjacent points at once by per-lane loads (lanes::gatherRow8).
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "udvr/reconstruct/quantile_interp.h"
#include "udvr/util/lanes.h"

namespace udvr {

/// The most vertices of a polyline expectedTf2QuantileRange takes (quantile levels + 1).
inline constexpr int kMaxPolylineVertices = 128;

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
};

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

namespace detail {
/// The next raster line (integer coordinate in [0, n − 1]) a coordinate moving from s with
/// slope ds crosses, the step to the one after it (±1), or none (line = −1, step 0).
template <class T>
UDVR_CPU_GPU UDVR_INLINE void firstLine(T s, T ds, int n, lanes::IntOf<T>& line,
                                        lanes::IntOf<T>& step) {
    using S = lanes::ScalarOf<T>;
    using I = lanes::IntOf<T>;
    // s is clamped to [−1, n] first (NaN → −1): lines lie in [0, n − 1] only, and the int must
    // not wrap.
    const T c =
        lanes::select(s > S(-1), lanes::min(s, lanes::splat<T>(S(n))), lanes::splat<T>(S(-1)));
    const T fl = [&] {
        if constexpr (lanes::kIsVector<T>) {
            const T tr = lanes::toFloat(lanes::truncToInt(c));
            return lanes::select(tr > c, tr - S(1), tr);
        } else {
            return std::floor(c);
        }
    }();
    const T ce = lanes::select(fl < c, fl + S(1), fl);
    const auto toInt = [](T v) {
        if constexpr (lanes::kIsVector<T>)
            return lanes::truncToInt(v);
        else
            return static_cast<int>(v);
    };
    const I up = lanes::max(toInt(fl) + 1, I{} + 0);          // ds > 0
    const I down = lanes::min(toInt(ce) - 1, I{} + (n - 1));  // ds < 0
    // A non-finite slope (an overflowed or NaN end) crosses no line: one piece, clamped.
    const auto finite = lanes::abs(ds) <= std::numeric_limits<S>::max();
    const auto rising = finite & (ds > S(0)), falling = finite & (ds < S(0));
    const auto upOk = rising & (up <= n - 1);
    const auto downOk = falling & (down >= 0);
    if constexpr (lanes::kIsVector<T>) {
        line = lanes::select(upOk, up, lanes::select(downOk, down, I{} - 1));
        step = lanes::select(upOk, I{} + 1, lanes::select(downOk, I{} - 1, I{}));
    } else {
        line = upOk ? up : (downOk ? down : -1);
        step = upOk ? 1 : (downOk ? -1 : 0);
    }
}
/// Segment parameter where the coordinate s0 + u·ds reaches `line` (+∞ for none).
template <class T>
UDVR_CPU_GPU UDVR_INLINE T lineParameter(T s0, T ds, lanes::IntOf<T> line, lanes::IntOf<T> step) {
    using S = lanes::ScalarOf<T>;
    T l;
    if constexpr (lanes::kIsVector<T>)
        l = lanes::toFloat(line);
    else
        l = static_cast<T>(line);
    const T u = (l - s0) / lanes::select(step != 0, ds, lanes::splat<T>(S(1)));
    return lanes::select(step != 0, u, lanes::splat<T>(std::numeric_limits<S>::infinity()));
}
/// The band (row of cells, 0 … H − 2) a walk at raster coordinate t moves in, from its next y
/// line and step (firstLine): the one below that line when rising, above it when falling, the
/// one at t when no line lies ahead.
template <class T>
UDVR_CPU_GPU UDVR_INLINE lanes::IntOf<T> bandAhead(T t, lanes::IntOf<T> lineY,
                                                   lanes::IntOf<T> stepY, int height) {
    using S = lanes::ScalarOf<T>;
    using I = lanes::IntOf<T>;
    I here;
    T f;
    rasterCell(rasterCoordinate<T>(t, S(0), S(1), height), height, here, f);
    const I band = lanes::select(stepY > 0, lineY - 1, lanes::select(stepY < 0, lineY, here));
    return lanes::max(lanes::min(band, I{} + (height - 2)), I{} + 0);
}
/// Cell `cell`'s run [lo, hi) of point columns in band `band` (Tf2Raster::cellRun, set).
template <class T, class Real>
UDVR_CPU_GPU UDVR_INLINE void runOf(const Tf2Raster<Real>& r, lanes::IntOf<T> cell,
                                    lanes::IntOf<T> band, lanes::MaskOf<T> live,
                                    lanes::IntOf<T>& lo, lanes::IntOf<T>& hi) {
    const lanes::IntOf<T> idx = (band * (r.width - 1) + cell) * 2;
    if constexpr (lanes::kIsVector<T>) {
        T a, b;
        lanes::gatherPair(r.cellRun, idx, live, a, b);
        lo = lanes::truncToInt(a);
        hi = lanes::truncToInt(b);
    } else {
        lo = static_cast<int>(r.cellRun[idx]);
        hi = static_cast<int>(r.cellRun[idx + 1]);
    }
}
/// The end, in the walk's direction, of the run holding `cell` (right: its hi, left: its lo);
/// `fallback` in lanes going neither way.
template <class T, class Real>
UDVR_CPU_GPU UDVR_INLINE lanes::IntOf<T> runEnd(const Tf2Raster<Real>& r, lanes::IntOf<T> cell,
                                                lanes::MaskOf<T> right, lanes::MaskOf<T> left,
                                                lanes::IntOf<T> band, lanes::MaskOf<T> live,
                                                lanes::IntOf<T> fallback) {
    using I = lanes::IntOf<T>;
    const I c = lanes::max(lanes::min(cell, I{} + (r.width - 2)), I{} + 0);
    I lo, hi;
    runOf<T>(r, c, band, live & (right | left), lo, hi);
    return lanes::select(right, hi, lanes::select(left, lo, fallback));
}
/// The x line firstLine found ahead of a walk in band `band`, replaced by the end of the run
/// the walk is in (the domain's edge lines, reached from outside, stay).
template <class T, class Real>
UDVR_CPU_GPU UDVR_INLINE lanes::IntOf<T> runLineAhead(const Tf2Raster<Real>& r,
                                                      lanes::IntOf<T> lineX, lanes::IntOf<T> stepX,
                                                      lanes::IntOf<T> band, lanes::MaskOf<T> live) {
    const auto right = (stepX > 0) & (lineX >= 1);           // in cell lineX − 1
    const auto left = (stepX < 0) & (lineX <= r.width - 2);  // in cell lineX
    return runEnd<T>(r, lanes::select(right, lineX - 1, lineX), right, left, band, live, lineX);
}
/// The x line after `lineX` (just reached) in the walk's direction: by cells the next line, by
/// runs the far end of the next run in band `band`; one past the domain's last line at its end
/// (the caller stops there).
template <bool kRuns, class T, class Real>
UDVR_CPU_GPU UDVR_INLINE lanes::IntOf<T> nextLineX(const Tf2Raster<Real>& r, lanes::IntOf<T> lineX,
                                                   lanes::IntOf<T> stepX, lanes::IntOf<T> band,
                                                   lanes::MaskOf<T> live) {
    if constexpr (!kRuns) return lineX + stepX;
    const auto right = (stepX > 0) & (lineX <= r.width - 2);  // into cell lineX
    const auto left = (stepX < 0) & (lineX >= 1);             // into cell lineX − 1
    return runEnd<T>(r, lanes::select(left, lineX - 1, lineX), right, left, band, live,
                     lineX + stepX);
}

/// One segment, weight 1: the source of tf2MeanAlongSegment's walk.
template <class T>
struct OneSegment {
    static constexpr bool kMany = false, kPooled = false;
    T xa, ya, xb, yb;
    /// Sets the next segment's ends and weight in the lanes of m that have one; returns those.
    UDVR_CPU_GPU UDVR_INLINE lanes::MaskOf<T> next(lanes::MaskOf<T> m, T& pa, T& qa, T& pb, T& qb,
                                                   T& w) const {
        pa = xa, qa = ya, pb = xb, qb = yb;
        w = lanes::splat<T>(lanes::ScalarOf<T>(1));
        return m;
    }
};

/// The walk of tf2MeanAlongSegment, by cells or (kRuns, r.cellRun set) by runs of cells, over
/// the segments of `source` (OneSegment, or a polyline: Σ weight × mean along each segment).
/// With Source::kMany a lane that finishes a segment starts its next one in place, so a batch
/// walks as long as its longest lane's total, not the sum over segments of the longest lane's;
/// with Source::kPooled the lanes' sums go to the source (flush) as each segment ends, and the
/// source's totals are the result (collect).
template <bool kRuns, class T, class Real, class Source>
UDVR_CPU_GPU UDVR_INLINE void segmentWalk(const Tf2Raster<Real>& r, Source& source,
                                          lanes::MaskOf<T> live, T out[4]) {
    using S = lanes::ScalarOf<T>;
    using I = lanes::IntOf<T>;
    const S ox = static_cast<S>(r.x0), oy = static_cast<S>(r.y0);
    const S ix = static_cast<S>(r.invDx), iy = static_cast<S>(r.invDy);
    T sa{}, ta{}, ds{}, dt{}, ux{}, uy{}, u0{}, weight{};
    I lineX{}, stepX{}, lineY{}, stepY{};
    // The lanes of m go on from segment parameter u, raster position (s, t): the lines ahead.
    const auto goOnFrom = [&](lanes::MaskOf<T> m, T u, T s, T t) {
        I lx, sx, ly, sy;
        detail::firstLine<T>(s, ds, r.width, lx, sx);
        detail::firstLine<T>(t, dt, r.height, ly, sy);
        if constexpr (kRuns)
            lx = detail::runLineAhead<T>(r, lx, sx, detail::bandAhead<T>(t, ly, sy, r.height), m);
        lineX = lanes::select(m, lx, lineX);
        stepX = lanes::select(m, sx, stepX);
        lineY = lanes::select(m, ly, lineY);
        stepY = lanes::select(m, sy, stepY);
        ux = lanes::select(m, detail::lineParameter<T>(sa, ds, lx, sx), ux);
        uy = lanes::select(m, detail::lineParameter<T>(ta, dt, ly, sy), uy);
        u0 = lanes::select(m, u, u0);
    };
    // Starts the next segment of the lanes of m that have one (returned).
    const auto begin = [&](lanes::MaskOf<T> m) {
        T xa{}, ya{}, xb{}, yb{}, w{};
        const lanes::MaskOf<T> got = source.next(m, xa, ya, xb, yb, w);
        if (!lanes::anyOf(got)) return got;
        // Raster coordinates, unclamped (pieces outside the domain clamp at evaluation).
        const T sa1 = (xa - ox) * ix, ta1 = (ya - oy) * iy;
        sa = lanes::select(got, sa1, sa);
        ta = lanes::select(got, ta1, ta);
        ds = lanes::select(got, (xb - ox) * ix - sa1, ds);
        dt = lanes::select(got, (yb - oy) * iy - ta1, dt);
        weight = lanes::select(got, w, weight);
        goOnFrom(got, T{}, sa1, ta1);
        return got;
    };
    for (int ch = 0; ch < 4; ++ch) out[ch] = T{};
    auto active = begin(live);
    // Gauss–Legendre on [0, 1]: nodes ½ ∓ ½√(3/5), ½; weights 5/18, 8/18, 5/18.
    constexpr S kNode = S(0.38729833462074168852), kW0 = S(5.0 / 18.0), kW1 = S(8.0 / 18.0);
    while (lanes::anyOf(active)) {
        // (max: a line found again after a jump may lie an ulp behind u0.)
        const T u1 = lanes::max(lanes::min(lanes::min(ux, uy), lanes::splat<T>(S(1))), u0);
        const T len = u1 - u0;
        const T mid = (u0 + u1) * S(0.5);
        const T nodes[3] = {mid - kNode * len, mid, mid + kNode * len};
        const S weights[3] = {kW0, kW1, kW0};
        // The piece lies in one raster cell (clamped outside the domain). A cell of α = 0 adds
        // nothing, and neither does the rest of the segment inside the block of cells closer
        // than its distance d: the segment jumps to where it leaves that block (exact).
        auto use = active;
        auto jump = lanes::MaskOf<T>{};
        T uJump{};
        I i, j;
        T fx, fy;
        detail::rasterCell(
            detail::rasterCoordinate<T>(lanes::fma(mid, ds, sa), S(0), S(1), r.width), r.width, i,
            fx);
        detail::rasterCell(
            detail::rasterCoordinate<T>(lanes::fma(mid, dt, ta), S(0), S(1), r.height), r.height, j,
            fy);
        if (r.cellEmptyDistance) {
            const T d = detail::rasterLoad<T>(r.cellEmptyDistance, j * (r.width - 1) + i, active);
            use = active & (d == S(0));
            jump = active & (d > S(1));
            if (lanes::anyOf(jump)) {
                // The block spans raster coordinates [i + 1 − d, i + d] along s, same along t.
                const auto leave = [&](I cell, T from, T slope) {
                    T c;
                    if constexpr (lanes::kIsVector<T>)
                        c = lanes::toFloat(cell);
                    else
                        c = static_cast<T>(cell);
                    const T inf = lanes::splat<T>(std::numeric_limits<S>::infinity());
                    const T safe = lanes::select(slope != S(0), slope, lanes::splat<T>(S(1)));
                    return lanes::select(
                        slope > S(0), (c + d - from) / safe,
                        lanes::select(slope < S(0), (c + S(1) - d - from) / safe, inf));
                };
                uJump = lanes::min(lanes::min(leave(i, sa, ds), leave(j, ta, dt)),
                                   lanes::splat<T>(S(1)));
            }
        }
        if (lanes::anyOf(use)) {
            // One load of the cell's (or its run's) corners serves the three nodes.
            I lo = i, hi = i + 1;
            if constexpr (kRuns) detail::runOf<T>(r, i, j, use, lo, hi);
            const Tf2Cell<T> cell(r, lo, hi, j, use);
            T ci, cj, invWidth = lanes::splat<T>(S(1));
            if constexpr (lanes::kIsVector<T>) {
                ci = lanes::toFloat(lo);
                cj = lanes::toFloat(j);
                if constexpr (kRuns) invWidth = S(1) / lanes::toFloat(lanes::max(hi - lo, I{} + 1));
            } else {
                ci = static_cast<T>(lo);
                cj = static_cast<T>(j);
                if constexpr (kRuns) invWidth = S(1) / static_cast<T>(hi - lo > 1 ? hi - lo : 1);
            }
            for (int n = 0; n < 3; ++n) {
                const T s =
                    detail::rasterCoordinate<T>(lanes::fma(nodes[n], ds, sa), S(0), S(1), r.width);
                const T t =
                    detail::rasterCoordinate<T>(lanes::fma(nodes[n], dt, ta), S(0), S(1), r.height);
                T v[4];
                cell.at(kRuns ? (s - ci) * invWidth : s - ci, t - cj, v);
                const T wl = lanes::select(use, len * weights[n] * weight, T{});
                for (int ch = 0; ch < 3; ++ch) out[ch] = lanes::fma(wl, v[3] * v[ch], out[ch]);
                out[3] = lanes::fma(wl, v[3], out[3]);
            }
        }
        // Step past the line(s) reached at u1; a lane is done at u = 1. With runs, a lane that
        // crossed a y line is in a new band whose runs differ: its x line is found again from
        // its position (a line found an ulp behind gives one empty piece, then the step).
        const auto atX = ux <= u1, atY = uy <= u1;
        if constexpr (lanes::kIsVector<T>) {
            lineY = lanes::select(atY, lineY + stepY, lineY);
            stepY = lanes::select(atY & ((lineY < 0) | (lineY > r.height - 1)), I{}, stepY);
        } else if (atY) {
            lineY += stepY;
            if (lineY < 0 || lineY > r.height - 1) stepY = 0;
        }
        I band{};
        if constexpr (kRuns)
            band = detail::bandAhead<T>(lanes::fma(u1, dt, ta), lineY, stepY, r.height);
        lineX = lanes::select(atX, detail::nextLineX<kRuns, T>(r, lineX, stepX, band, active & atX),
                              lineX);
        if constexpr (kRuns) {
            if (lanes::anyOf(active & atY)) {
                I lx, sx;
                detail::firstLine<T>(lanes::fma(u1, ds, sa), ds, r.width, lx, sx);
                lx = detail::runLineAhead<T>(r, lx, sx, band, active & atY);
                lineX = lanes::select(atY, lx, lineX);
                stepX = lanes::select(atY, sx, stepX);
            }
        }
        const auto movedX = kRuns ? atX | atY : atX;
        if constexpr (lanes::kIsVector<T>)
            stepX = lanes::select(movedX & ((lineX < 0) | (lineX > r.width - 1)), I{}, stepX);
        else if (movedX && (lineX < 0 || lineX > r.width - 1))
            stepX = 0;
        ux = lanes::select(movedX, detail::lineParameter<T>(sa, ds, lineX, stepX), ux);
        uy = lanes::select(atY, detail::lineParameter<T>(ta, dt, lineY, stepY), uy);
        u0 = u1;
        // Only a jump past the piece's end: restarting at a line found an ulp behind would walk
        // the same piece again, forever.
        jump = jump & (uJump > u1);
        if (lanes::anyOf(jump))  // restart the line walk where the segment leaves the block
            goOnFrom(jump, uJump, lanes::fma(uJump, ds, sa), lanes::fma(uJump, dt, ta));
        const auto walked = active;
        active = active & (u0 < S(1));
        if constexpr (Source::kMany) {
            const auto finished = walked & !active;
            if (lanes::anyOf(finished)) {
                if constexpr (Source::kPooled) source.flush(finished, out);
                active = active | begin(finished);
            }
        }
    }
    if constexpr (Source::kPooled) source.collect(out);
}

/// One raster cell of one row: points i and i + 1 (α and c each linear in the fraction
/// σ ∈ [0, 1] between them); all 0 where not loaded.
template <class T>
struct Tf2RowCell {
    T p0[4] = {}, p1[4] = {};  // (r, g, b, α) at σ = 0 and 1

    Tf2RowCell() = default;
    /// Points i, i + 1 of row j from base = (j·W + i)·4 (lanes of `live`; 0 elsewhere).
    UDVR_CPU_GPU UDVR_INLINE Tf2RowCell(const float* rgba, lanes::IntOf<T> base,
                                        lanes::MaskOf<T> live) {
        rasterPoints2<T>(rgba, base, live, p0, p1);
    }
    /// Mean of (α·r, α·g, α·b, α) over σ ∈ [f1, f2] (the value at f1 where f1 = f2): with
    /// α = a0 + da·σ and c = c0 + dc·σ, α·c = a0·c0 + (a0·dc + da·c0)·σ + da·dc·σ², whose mean
    /// takes m1 = (f1 + f2)/2 for σ and m2 = (f1² + f1·f2 + f2²)/3 for σ².
    UDVR_CPU_GPU UDVR_INLINE void mean(T f1, T f2, T out[4]) const {
        using S = lanes::ScalarOf<T>;
        const T m1 = (f1 + f2) * S(0.5);
        const T m2 = lanes::fma(f1, f1, lanes::fma(f1, f2, f2 * f2)) * S(1.0 / 3.0);
        const T a0 = p0[3], da = p1[3] - p0[3];
        for (int ch = 0; ch < 3; ++ch) {
            const T c0 = p0[ch], dc = p1[ch] - p0[ch];
            out[ch] = lanes::fma(da * dc, m2, lanes::fma(lanes::fma(a0, dc, da * c0), m1, a0 * c0));
        }
        out[3] = lanes::fma(da, m1, a0);
    }
    /// Lane-wise m ? a : b.
    UDVR_CPU_GPU UDVR_INLINE static Tf2RowCell pick(lanes::MaskOf<T> m, const Tf2RowCell& a,
                                                    const Tf2RowCell& b) {
        Tf2RowCell c;
        for (int ch = 0; ch < 4; ++ch) {
            c.p0[ch] = lanes::select(m, a.p0[ch], b.p0[ch]);
            c.p1[ch] = lanes::select(m, a.p1[ch], b.p1[ch]);
        }
        return c;
    }
};

/// What rowConstantMean needs of one end (x, y) of a segment, in data units: its coordinates
/// at construction, the raster's values (`load`) only for lanes whose segment takes the closed
/// form, and each lane once, so that the polyline's segments share their ends' reads
/// (expectedTf2QuantileRange). Needs r.rowPrefix.
template <class T>
struct Tf2RowEnd {
    using I = lanes::IntOf<T>;
    T s{}, t{};            // raster coordinates: s unclamped, t clamped to [0, H − 1]
    T f{};                 // fraction of s, clamped to [0, W − 1], in its cell
    I cell{}, row{};       // that cell (≤ W − 2) and row ⌊t⌋
    T sameUpTo{};          // Tf2Raster::rowSameUpTo at the row
    Tf2RowCell<T> values;  // the row at points cell, cell + 1
    T prefix[4] = {}, prefixLo[4] = {};  // the row's prefix integrals at point `cell`, hi + lo
    T partial[4] = {};  // ∫ of the row's P from point `cell` to s (P clamped beyond the domain)
    lanes::MaskOf<T> hasValues{}, hasPrefix{};  // lanes whose values, prefix (and partial) are read

    Tf2RowEnd() = default;
    template <class Real>
    UDVR_CPU_GPU UDVR_INLINE Tf2RowEnd(const Tf2Raster<Real>& r, T x, T y, lanes::MaskOf<T> live) {
        using S = lanes::ScalarOf<T>;
        s = (x - static_cast<S>(r.x0)) * static_cast<S>(r.invDx);
        t = rasterCoordinate<T>(y, static_cast<S>(r.y0), static_cast<S>(r.invDy), r.height);
        if constexpr (lanes::kIsVector<T>)
            row = lanes::truncToInt(t);
        else
            row = static_cast<int>(t);
        rasterCell(rasterCoordinate<T>(s, S(0), S(1), r.width), r.width, cell, f);
        // A raster constant in y (every row the same, as a 1D TF sampled as a TF2) needs no
        // lookup.
        sameUpTo = r.rowSameUpTo[0] >= static_cast<float>(r.height - 1)
                       ? lanes::splat<T>(S(r.height - 1))
                       : rasterLoad<T>(r.rowSameUpTo, row, live);
    }
    /// Reads the row's points for the lanes of `needValues` and its prefix for those of
    /// `needPrefix` (a subset), each lane once; with the prefix, `partial`: f × the cell's mean
    /// over [0, f], plus P at the clamped point times how far s lies beyond it, so that prefix +
    /// partial = ∫ from point 0 to s.
    template <class Real>
    UDVR_CPU_GPU UDVR_INLINE void load(const Tf2Raster<Real>& r, lanes::MaskOf<T> needValues,
                                       lanes::MaskOf<T> needPrefix) {
        using S = lanes::ScalarOf<T>;
        const I base = row * r.width + cell;
        const lanes::MaskOf<T> mv = needValues & !hasValues;
        if (lanes::anyOf(mv)) {
            hasValues = hasValues | mv;
            values = Tf2RowCell<T>::pick(mv, Tf2RowCell<T>(r.rgba, base * 4, mv), values);
        }
        const lanes::MaskOf<T> mp = needPrefix & !hasPrefix;
        if (!lanes::anyOf(mp)) return;
        hasPrefix = hasPrefix | mp;
        T hi[4], lo[4];  // the point's 8 floats: hi (4), then lo (4)
        rasterPoints2<T>(r.rowPrefix, base * 8, mp, hi, lo);
        T toF[4], beyond[4] = {};
        values.mean(T{}, f, toF);
        T clamped;
        if constexpr (lanes::kIsVector<T>)
            clamped = lanes::toFloat(cell) + f;
        else
            clamped = static_cast<T>(cell) + f;
        const T outside = s - clamped;  // 0 within the domain
        if (lanes::anyOf(mp & (outside != S(0)))) values.mean(f, f, beyond);
        for (int ch = 0; ch < 4; ++ch) {
            prefix[ch] = lanes::select(mp, hi[ch], prefix[ch]);
            prefixLo[ch] = lanes::select(mp, lo[ch], prefixLo[ch]);
            partial[ch] =
                lanes::select(mp, lanes::fma(outside, beyond[ch], f * toF[ch]), partial[ch]);
        }
    }
};

/// The lanes of `live` whose segment from end a to end b sees one row's function: the rows
/// [⌊t_lo⌋, ⌈t_hi⌉] it spans are identical (Tf2Raster::rowSameUpTo), and its ends are finite
/// (the others walk).
template <class T>
UDVR_CPU_GPU UDVR_INLINE lanes::MaskOf<T> rowConstantLanes(const Tf2RowEnd<T>& a,
                                                           const Tf2RowEnd<T>& b,
                                                           lanes::MaskOf<T> live) {
    using S = lanes::ScalarOf<T>;
    T topFloor;
    if constexpr (lanes::kIsVector<T>)
        topFloor = lanes::toFloat(lanes::max(a.row, b.row));
    else
        topFloor = static_cast<T>(a.row > b.row ? a.row : b.row);
    const T top =
        topFloor + lanes::select(topFloor < lanes::max(a.t, b.t), lanes::splat<T>(S(1)), T{});
    constexpr S kMax = std::numeric_limits<S>::max();
    // Named masks: `&` of bools over calls is what clang's -Wbitwise-instead-of-logical flags.
    const auto finiteA = lanes::abs(a.s) <= kMax, finiteB = lanes::abs(b.s) <= kMax;
    const auto sameRows = lanes::select(a.t <= b.t, a.sameUpTo, b.sameUpTo) >= top;
    return live & finiteA & finiteB & sameRows;
}

/// Where the TF2 does not change with y over a segment's y range — that range lies on one row
/// line, or rows j … j' of the raster are identical and cover [⌊t_lo⌋, ⌈t_hi⌉]
/// (Tf2Raster::rowSameUpTo) — the segment mean is the mean of row j's function P(s) over the
/// segment's x range [lo, hi] (raster coordinates; P clamped outside [0, W − 1]):
///   (P(0)·|[lo, hi] ∩ (−∞, 0]| + ∫ P over [lo, hi] ∩ [0, W − 1] + P(W − 1)·|… ∩ [W − 1, ∞)|)
///   / (hi − lo).
/// With il ≤ ih the cells of the clamped ends, fl, fh their fractions and L(i, f) = ∫₀^f of
/// cell i (a closed form), the middle is
///   - one cell (il = ih): (fh − fl) × the cell's mean over [fl, fh];
///   - adjacent cells: ∫ over [fl, 1] of cell il + L(ih, fh);
///   - ih ≥ il + 2: prefix(ih) − prefix(il) + L(ih, fh) − L(il, fl), the prefix integrals as
///     hi + lo pairs, so their difference keeps float's relative precision; the range is then
///     ≥ 1 cell long, so the L terms (≤ one cell's integral) cost at most float's relative
///     error of the mean.
/// No piece subtracts sums larger than the range's integral by more than that, so short and
/// vertical segments keep their digits; P(lo) where hi = lo. Each end evaluates one closed form
/// on its own cell (no values are swapped between the ends). For the lanes of rowConstantLanes,
/// both ends loaded there (other lanes' out is junk): no reads, against a walk over every cell
/// (or run) the segment crosses.
template <class T>
UDVR_CPU_GPU UDVR_INLINE void rowConstantMean(const Tf2RowEnd<T>& a, const Tf2RowEnd<T>& b,
                                              int width, T out[4]) {
    using S = lanes::ScalarOf<T>;
    using I = lanes::IntOf<T>;
    const T unit = lanes::splat<T>(S(1));
    const auto aLeft = a.s <= b.s;
    const I reach = lanes::select(aLeft, b.cell - a.cell, a.cell - b.cell);  // ih − il ≥ 0
    const auto one = reach == 0, spans = reach >= 2;
    // Each end's closed form over [g1, g2] of its cell with weight w (the mean is symmetric in
    // its bounds): one cell: end a over [f_a, f_b], end b nothing; else the right end L(ih, fh),
    // the left end ∫ over [fl, 1] (adjacent) or −L(il, fl) (spans).
    const T zero{};
    const T ga1 = lanes::select(one | (aLeft & !spans), a.f, zero);
    const T ga2 = lanes::select(one, b.f, lanes::select(aLeft & !spans, unit, a.f));
    const T wa =
        lanes::select(one, lanes::abs(b.f - a.f),
                      lanes::select(aLeft, lanes::select(spans, zero - a.f, unit - a.f), a.f));
    const auto bNear = !(aLeft | spans);  // b the left end of adjacent cells
    const T gb1 = lanes::select(bNear, b.f, zero);
    const T gb2 = lanes::select(bNear, unit, b.f);
    const T wb = lanes::select(
        one, zero, lanes::select(!aLeft, lanes::select(spans, zero - b.f, unit - b.f), b.f));
    T ma[4], mb[4];
    a.values.mean(ga1, ga2, ma);
    b.values.mean(gb1, gb2, mb);
    const T lo = lanes::min(a.s, b.s), hi = lanes::max(a.s, b.s);
    const T len = hi - lo;
    const auto point = !(len > S(0));
    const T inv = S(1) / lanes::select(point, unit, len);
    // Lengths of [lo, hi] below 0 and above W − 1, where P is P(0) = P(lo) and P(W − 1) = P(hi).
    const T below = lanes::max(lanes::min(hi, zero) - lo, zero);
    const T above = lanes::max(hi - lanes::max(lo, lanes::splat<T>(S(width - 1))), zero);
    const auto edge = point | (below > S(0)) | (above > S(0));
    T pLo[4] = {}, pHi[4] = {};
    if (lanes::anyOf(edge)) {
        T pa[4], pb[4];
        a.values.mean(a.f, a.f, pa);
        b.values.mean(b.f, b.f, pb);
        for (int c = 0; c < 4; ++c) {
            pLo[c] = lanes::select(aLeft, pa[c], pb[c]);
            pHi[c] = lanes::select(aLeft, pb[c], pa[c]);
        }
    }
    const T sign =
        lanes::select(aLeft, unit, zero - unit);  // prefix(ih) − prefix(il) = sign·(b − a)
    for (int c = 0; c < 4; ++c) {
        const T full = lanes::select(
            spans, sign * ((b.prefix[c] - a.prefix[c]) + (b.prefixLo[c] - a.prefixLo[c])), zero);
        const T sum = lanes::fma(
            below, pLo[c],
            lanes::fma(above, pHi[c], lanes::fma(wa, ma[c], lanes::fma(wb, mb[c], full))));
        out[c] = lanes::select(point, pLo[c], sum * inv);
    }
}

/// The segment from end a to end b (r.rowPrefix set) by rowConstantMean in the lanes of `live`
/// that may take it (rowConstantLanes, returned; their mean in out, the other lanes' out 0).
template <class T, class Real>
UDVR_CPU_GPU UDVR_INLINE lanes::MaskOf<T> rowConstantSegment(const Tf2Raster<Real>& r,
                                                             Tf2RowEnd<T>& a, Tf2RowEnd<T>& b,
                                                             lanes::MaskOf<T> live, T out[4]) {
    using S = lanes::ScalarOf<T>;
    using I = lanes::IntOf<T>;
    const lanes::MaskOf<T> done = rowConstantLanes<T>(a, b, live);
    for (int ch = 0; ch < 4; ++ch) out[ch] = T{};
    if (!lanes::anyOf(done)) return done;
    // Both ends' row points, and the prefix where full cells lie between the ends' cells. (A
    // gather of the cells' empty distances to skip these reads where both ends lie in one block
    // of α = 0 cost more than the reads: 1D TF as TF2, 512² tangle, one thread, 680 → 634 ms.)
    const I step = b.cell - a.cell;
    const I reach = lanes::max(step, I{} - step);
    const lanes::MaskOf<T> spans = done & (reach >= 2);
    a.load(r, done, spans);
    b.load(r, done, spans);
    T row[4];
    if (lanes::anyOf(done & !spans)) {
        rowConstantMean<T>(a, b, r.width, row);
    } else {
        // Every segment spans a full cell or more: the difference of the ends' integrals from
        // point 0 (prefix hi + lo, then the partials) over b.s − a.s, in either order
        // (rowConstantMean's spans case, the lengths beyond the domain in the partials);
        // 634 → 572 ms.
        const T inv = S(1) / (b.s - a.s);
        for (int c = 0; c < 4; ++c)
            row[c] = ((b.prefix[c] - a.prefix[c]) + (b.prefixLo[c] - a.prefixLo[c]) +
                      (b.partial[c] - a.partial[c])) *
                     inv;
    }
    for (int ch = 0; ch < 4; ++ch) out[ch] = lanes::select(done, row[ch], T{});
    return done;
}
/// segmentWalk, by runs where r.cellRun is set.
template <class T, class Real, class Source>
UDVR_CPU_GPU UDVR_INLINE void segmentWalkOf(const Tf2Raster<Real>& r, Source& source,
                                            lanes::MaskOf<T> live, T out[4]) {
    if (r.cellRun)
        segmentWalk<true, T>(r, source, live, out);
    else
        segmentWalk<false, T>(r, source, live, out);
}

/// The segments j = 1 … count − 1 of a polyline through the vertices (x[j], g[j]), weights
/// mass[j], skipping those whose bit is set in `skip` (taken by the closed form), in turn: the
/// source of expectedTf2QuantileRange's walk for a scalar T (lanes take PooledPolylineSegments).
template <class T>
struct PolylineSegments {
    static_assert(!lanes::kIsVector<T>);
    static constexpr bool kMany = true, kPooled = false;
    const T* x;
    const T* g;
    const T* mass;  // [count]
    int count;
    int skip = 0;  // bit j (< 32): segment j is not walked
    int seg = 0;   // the segment walked (0 before the first)

    UDVR_CPU_GPU UDVR_INLINE bool next(bool m, T& xa, T& ya, T& xb, T& yb, T& w) {
        if (!m) return false;
        do ++seg;
        while (seg < count && seg < 32 && ((static_cast<unsigned>(skip) >> seg) & 1u));
        if (seg >= count) return false;
        xa = x[seg - 1], ya = g[seg - 1], xb = x[seg], yb = g[seg];
        w = mass[seg];
        return true;
    }
};

/// The segments of the kWidth polylines of a batch (vertices x[j], g[j], weights mass[j],
/// segments whose bit j < 32 is set in their lane's `skip` left out; only the lanes of `live`)
/// as one pool: a lane that finishes a segment takes the next
/// one left in the pool, of whichever polyline, and hands its sum to that polyline's total
/// (flush), so the lanes stay busy until the pool is empty rather than each waiting for the
/// longest polyline. For the lanes to finish together the pool hands out its longest segments
/// first (by the raster lines they cross, |Δs| + |Δt|, in powers of two), and with kParts
/// (for pools of few segments a lane: iqr and the quartile views have one) it cuts the long ones
/// into parts [u0, u1] of their parameter (exact: the mean over [0, 1] is Σ (u1 − u0) × the
/// mean over the parts), each crossing at most a quarter of a lane's share of the lines.
/// Lane vectors only.
template <bool kParts>
struct PooledPolylineSegments {
    static constexpr bool kMany = true, kPooled = true;
    using Vf = lanes::Vf;
    static constexpr int kCapacity = lanes::kWidth * kMaxPolylineVertices;
    const Vf* x;
    const Vf* g;
    const float* mass;
    int items = 0, taken = 0;
    std::int16_t itemLane[kCapacity];      // polyline of each item
    std::int16_t itemSeg[kCapacity];       // its segment
    float itemU0[kParts ? kCapacity : 1];  // with kParts, its part [u0, u1] of the segment
    float itemU1[kParts ? kCapacity : 1];
    std::int32_t laneOf[lanes::kWidth] = {};  // each lane's polyline
    float total[4][lanes::kWidth] = {};       // Σ weight × mean, per polyline

    /// invDx, invDy: raster cells per data unit along x and y (Tf2Raster).
    PooledPolylineSegments(const Vf* xs, const Vf* gs, const float* m, int count, lanes::Vi skip,
                           lanes::Mask live, float invDx, float invDy)
        : x(xs), g(gs), mass(m) {
        // Class 0 … 15 of a segment (or part) crossing n lines, longest first: 15 − bit width
        // of n (0 for n ≥ 16384 and NaN, from non-finite ends).
        constexpr int kClasses = 16;
        const auto classOf = [](float n) {
            return n < 16384.0f
                       ? kClasses - 1 -
                             static_cast<int>(std::bit_width(static_cast<std::uint32_t>(n)))
                       : 0;
        };
        std::uint8_t cls[kCapacity];
        float lines[kParts ? kCapacity : 1];
        int start[kClasses + 1] = {};
        const std::uint32_t liveBits = lanes::bits(live);
        for (int l = 0; l < lanes::kWidth; ++l) {
            if (!((liveBits >> l) & 1u)) continue;
            for (int j = 1; j < count; ++j) {
                if (j < 32 && ((static_cast<std::uint32_t>(skip[l]) >> j) & 1u)) continue;
                const float n = std::fabs(x[j][l] - x[j - 1][l]) * invDx +
                                std::fabs(g[j][l] - g[j - 1][l]) * invDy;
                if constexpr (kParts) lines[items] = n;
                cls[items] = static_cast<std::uint8_t>(classOf(n));
                ++start[cls[items] + 1];
                itemLane[items] = static_cast<std::int16_t>(l);
                itemSeg[items] = static_cast<std::int16_t>(j);
                ++items;
            }
        }
        std::int16_t lane[kCapacity], seg[kCapacity];
        if constexpr (!kParts) {
            for (int c = 0; c < kClasses; ++c) start[c + 1] += start[c];
            for (int i = 0; i < items; ++i) {
                const int to = start[cls[i]]++;
                lane[to] = itemLane[i];
                seg[to] = itemSeg[i];
            }
        } else {
            // Parts of at most `chunk` lines (≥ 16: each part costs a start), as many as fit.
            float sum = 0.0f;
            for (int i = 0; i < items; ++i)
                if (lines[i] <= std::numeric_limits<float>::max()) sum += lines[i];
            const float chunk = std::max(16.0f, sum / static_cast<float>(4 * lanes::kWidth));
            int parts[kCapacity];
            int room = kCapacity - items;
            for (int c = 0; c <= kClasses; ++c) start[c] = 0;
            for (int i = 0; i < items; ++i) {
                int k = 1;
                if (lines[i] > chunk && lines[i] <= std::numeric_limits<float>::max()) {
                    k = static_cast<int>(
                        std::min(std::ceil(lines[i] / chunk), static_cast<float>(1 + room)));
                    room -= k - 1;
                    cls[i] = static_cast<std::uint8_t>(classOf(lines[i] / static_cast<float>(k)));
                }
                parts[i] = k;
                start[cls[i] + 1] += k;
            }
            for (int c = 0; c < kClasses; ++c) start[c + 1] += start[c];
            for (int i = 0; i < items; ++i) {
                const float step = 1.0f / static_cast<float>(parts[i]);
                for (int p = 0; p < parts[i]; ++p) {
                    const int to = start[cls[i]]++;
                    lane[to] = itemLane[i];
                    seg[to] = itemSeg[i];
                    itemU0[to] = static_cast<float>(p) * step;
                    itemU1[to] = p + 1 == parts[i] ? 1.0f : static_cast<float>(p + 1) * step;
                }
            }
        }
        items = start[kClasses];
        std::memcpy(itemLane, lane, sizeof(std::int16_t) * static_cast<std::size_t>(items));
        std::memcpy(itemSeg, seg, sizeof(std::int16_t) * static_cast<std::size_t>(items));
    }
    lanes::Mask next(lanes::Mask m, Vf& xa, Vf& ya, Vf& xb, Vf& yb, Vf& w) {
        std::int32_t seg[lanes::kWidth] = {};
        const int first = taken;
        std::uint32_t got = 0;
        for (std::uint32_t b = lanes::bits(m); b != 0 && taken < items; b &= b - 1) {
            const int l = std::countr_zero(b);
            laneOf[l] = itemLane[taken];
            seg[l] = itemSeg[taken];
            ++taken;
            got |= 1u << l;
        }
        const lanes::Mask gotMask = lanes::fromBits(got);
        if (got == 0) return gotMask;
        lanes::Vi j, polyline;
        std::memcpy(&j, seg, sizeof j);
        std::memcpy(&polyline, laneOf, sizeof polyline);
        j = lanes::select(gotMask, j, lanes::Vi{} + 1);
        const auto at = [&](const Vf* v, lanes::Vi k) {
            return lanes::gather(reinterpret_cast<const float*>(v), k * lanes::kWidth + polyline,
                                 gotMask);
        };
        xa = at(x, j - 1), ya = at(g, j - 1), xb = at(x, j), yb = at(g, j);
        w = lanes::gather(mass, j, gotMask);
        if constexpr (kParts) toParts(got, first, xa, ya, xb, yb, w);
        return gotMask;
    }
    /// The parts' ends and weights of the items next() handed out from `first` on, to the
    /// lanes of `got` in order.
    void toParts(std::uint32_t got, int first, Vf& xa, Vf& ya, Vf& xb, Vf& yb, Vf& w) const {
        float u0[lanes::kWidth] = {}, u1[lanes::kWidth] = {};
        for (int item = first; got != 0; got &= got - 1, ++item) {
            const int l = std::countr_zero(got);
            u0[l] = itemU0[item];
            u1[l] = itemU1[item];
        }
        // A whole segment (u0 = 0, u1 = 1) keeps its vertices.
        const Vf a = lanes::load(u0), b = lanes::load(u1), x0 = xa, y0 = ya;
        const Vf dx = xb - x0, dy = yb - y0;
        xa = lanes::select(a == 0.0f, x0, lanes::fma(a, dx, x0));
        ya = lanes::select(a == 0.0f, y0, lanes::fma(a, dy, y0));
        xb = lanes::select(b == 1.0f, xb, lanes::fma(b, dx, x0));
        yb = lanes::select(b == 1.0f, yb, lanes::fma(b, dy, y0));
        w = w * (b - a);
    }
    /// Adds the lanes of m to their polylines' totals and clears them.
    void flush(lanes::Mask m, Vf out[4]) {
        for (std::uint32_t b = lanes::bits(m); b != 0; b &= b - 1) {
            const int l = std::countr_zero(b);
            for (int ch = 0; ch < 4; ++ch) total[ch][laneOf[l]] += out[ch][l];
        }
        for (int ch = 0; ch < 4; ++ch) out[ch] = lanes::select(m, Vf{}, out[ch]);
    }
    void collect(Vf out[4]) const {
        for (int ch = 0; ch < 4; ++ch) out[ch] = lanes::load(total[ch]);
    }
};
/// Whether pooledPolylineWalk cuts long segments into parts (PooledPolylineSegments<true>): where
/// the lanes of `walk` have fewer than 4 segments each of their `count` − 1 (skipped ones counted).
inline bool pooledWalkCuts(lanes::Mask walk, int count) {
    return std::popcount(lanes::bits(walk)) * (count - 1) < 4 * lanes::kWidth;
}
/// The walk over a PooledPolylineSegments of the lanes of `walk`, out of line: inlined into the
/// ray loop it made the frames that seldom walk (the 1D TF as TF2) ~3 % slower.
template <class Real>
UDVR_NOINLINE void pooledPolylineWalk(const Tf2Raster<Real>& r, const lanes::Vf* x,
                                      const lanes::Vf* g, const float* mass, int count,
                                      lanes::Vi skip, lanes::Mask walk, lanes::Vf out[4]) {
    const float ix = static_cast<float>(r.invDx), iy = static_cast<float>(r.invDy);
    if (pooledWalkCuts(walk, count)) {
        PooledPolylineSegments<true> pool(x, g, mass, count, skip, walk, ix, iy);
        segmentWalkOf<lanes::Vf>(r, pool, lanes::allTrue<lanes::Vf>(), out);
    } else {
        PooledPolylineSegments<false> pool(x, g, mass, count, skip, walk, ix, iy);
        segmentWalkOf<lanes::Vf>(r, pool, lanes::allTrue<lanes::Vf>(), out);
    }
}
}  // namespace detail

/// Mean of TF2 (α·c and α) along the segment from (xa, ya) to (xb, yb) in data units:
/// ∫₀¹ TF2(P_a + u·(P_b − P_a)) du, exactly. The segment is split where it crosses a raster
/// line (including the domain's edges, where clamping starts) — or, with r.cellRun, only where
/// it leaves a run of cells over which the raster is bilinear (within the runs' tolerance); on
/// each piece α and c are quadratic in u, α·c quartic, so 3-point Gauss–Legendre is exact. A
/// zero-length segment gives TF2 at the point. Cost: 3 lookups per piece; lanes loop until
/// their longest segment is done. With r.rowPrefix, segments whose y range sees one row's
/// function (a TF2 constant in y there) take detail::rowConstantMean instead: O(1).
template <class T, class Real>
UDVR_CPU_GPU UDVR_INLINE void tf2MeanAlongSegment(const Tf2Raster<Real>& r, T xa, T ya, T xb, T yb,
                                                  lanes::MaskOf<T> live, T out[4]) {
    if (r.rowPrefix) {
        detail::Tf2RowEnd<T> a(r, xa, ya, live), b(r, xb, yb, live);
        if (!lanes::anyOf(live & !detail::rowConstantSegment<T>(r, a, b, live, out))) return;
    }
    detail::OneSegment<T> one{xa, ya, xb, yb};
    detail::segmentWalkOf<T>(r, one, live, out);
}

/// Quantile-range with a TF2 (SPEC §9): the rank-coupled polyline (X(t), G(t)) through the
/// vertices (x[j], g[j]), j = 0 … count − 1 (count ≤ kMaxPolylineVertices); Σ_j mass_j × mean
/// of TF2 along segment j / Σ mass (levels: equal masses for even levels, as
/// expectedTfQuantileRange). With r.rowPrefix the segments of the lanes that may take
/// rowConstantMean take it (each vertex's row data loaded once for the two segments that share
/// it; past 32 segments only lanes whose every segment may); one walk takes the rest: in a
/// scalar each segment in turn, in lanes the batch's segments as one pool
/// (PooledPolylineSegments; a sample's total then sums its segments in the order they finish,
/// which the other samples of the batch decide: deterministic, within float rounding of the
/// per-lane order).
template <class T, class Real>
UDVR_CPU_GPU UDVR_INLINE void expectedTf2QuantileRange(const Tf2Raster<Real>& r, const T* x,
                                                       const T* g, int count,
                                                       const QuantileLevels& levels,
                                                       lanes::MaskOf<T> live, T out[4]) {
    using S = lanes::ScalarOf<T>;
    using I = lanes::IntOf<T>;
    S mass[kMaxPolylineVertices];
    mass[0] = S(0);
    for (int j = 1; j < count; ++j) mass[j] = static_cast<S>(levels.mass(j));
    for (int ch = 0; ch < 4; ++ch) out[ch] = T{};
    I skip{};                      // per lane, bit j: segment j took the closed form
    lanes::MaskOf<T> walk = live;  // lanes with a segment to walk
    if (r.rowPrefix) {
        // Up to 32 segments a lane's skip bits say which took the closed form; beyond, a lane
        // takes it only if every segment may, else walks them all.
        const bool perSegment = count <= 32;
        detail::Tf2RowEnd<T> prev(r, x[0], g[0], live);
        lanes::MaskOf<T> closed = live;  // lanes whose every segment takes the closed form
        T sum[4] = {};
        for (int j = 1; j < count; ++j) {
            detail::Tf2RowEnd<T> next(r, x[j], g[j], live);
            T m[4];
            const lanes::MaskOf<T> done = detail::rowConstantSegment<T>(r, prev, next, live, m);
            const T w = lanes::splat<T>(mass[j]);
            for (int ch = 0; ch < 4; ++ch) sum[ch] = lanes::fma(w, m[ch], sum[ch]);
            if (perSegment) skip = skip | lanes::select(done, I{} + (1 << j), I{});
            closed = closed & done;
            prev = next;
        }
        for (int ch = 0; ch < 4; ++ch)
            out[ch] = perSegment ? sum[ch] : lanes::select(closed, sum[ch], T{});
        walk = live & !closed;
    }
    if (count >= 2 && lanes::anyOf(walk)) {
        T walked[4];
        if constexpr (lanes::kIsVector<T>) {
            detail::pooledPolylineWalk(r, x, g, mass, count, skip, walk, walked);
        } else {
            detail::PolylineSegments<T> segments{x, g, mass, count, skip};
            detail::segmentWalkOf<T>(r, segments, walk, walked);
        }
        for (int ch = 0; ch < 4; ++ch) out[ch] += walked[ch];
    }
    const S inv = levels.template inverseTotal<S>(count);
    for (int ch = 0; ch < 4; ++ch) out[ch] *= inv;
}

}  // namespace udvr
