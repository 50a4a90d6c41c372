#pragma once
// The exact mean of a raster TF2 along segments (SPEC §9): the walk over the raster lines a
// segment crosses (segmentWalk: per cell, the mean of the bilinear α and the α·c products in
// closed form), and the closed form of segments inside one row of constant TF2
// (rowConstantSegment). Sources hand the walk its segments (expected_tf2.h: one polyline, or
// the pooled segments of a batch). Over T ∈ {double, float, lanes::Vf}.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "udvr/classify/tf2_raster.h"

namespace udvr {

namespace detail {
/// The next raster line (integer coordinate in [0, n − 1], n per lane) a coordinate moving from
/// s with slope ds crosses, the step to the one after it (±1), or none (line = −1, step 0).
template <class T>
UDVR_CPU_GPU UDVR_INLINE void firstLineN(T s, T ds, lanes::IntOf<T> n, lanes::IntOf<T>& line,
                                         lanes::IntOf<T>& step) {
    using S = lanes::ScalarOf<T>;
    using I = lanes::IntOf<T>;
    const auto toInt = [](T v) {
        if constexpr (lanes::kIsVector<T>)
            return lanes::truncToInt(v);
        else
            return static_cast<int>(v);
    };
    T nf;
    if constexpr (lanes::kIsVector<T>)
        nf = lanes::toFloat(n);
    else
        nf = static_cast<T>(n);
    // s is clamped to [−1, n] first (NaN → −1): lines lie in [0, n − 1] only, and the int must
    // not wrap.
    const T c = lanes::select(s > S(-1), lanes::min(s, nf), lanes::splat<T>(S(-1)));
    const T fl = [&] {
        if constexpr (lanes::kIsVector<T>) {
            const T tr = lanes::toFloat(lanes::truncToInt(c));
            return lanes::select(tr > c, tr - S(1), tr);
        } else {
            return std::floor(c);
        }
    }();
    const T ce = lanes::select(fl < c, fl + S(1), fl);
    const I up = lanes::max(toInt(fl) + 1, I{} + 0);
    const I down = lanes::min(toInt(ce) - 1, n - 1);
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

/// firstLineN with one line count n for all lanes.
template <class T>
UDVR_CPU_GPU UDVR_INLINE void firstLine(T s, T ds, int n, lanes::IntOf<T>& line,
                                        lanes::IntOf<T>& step) {
    firstLineN<T>(s, ds, lanes::IntOf<T>{} + n, line, step);
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
// ---- The banded walk (Tf2Raster::bandPrefix) ------------------------------------------------
// A segment walks the raster lines of the axis it crosses fewer of (p, the walked axis; q the
// other). Between two crossings it lies in one band of cells between two p lines (or beyond
// the domain, where p clamps), and there the cross fraction φ (p − band) is linear in q:
// φ(q) = φ_c + k·(q − c). Along the band, cell l (q ∈ [l, l + 1], τ = q − l) has α and each
// colour bilinear in (φ, τ): α = A0(τ) + φ·A1(τ), c = C0(τ) + φ·C1(τ) with A0, A1, C0, C1
// linear in τ, so with φ = φ0 + k·q (φ0 = φ at q = 0)
//   ∫ α·c dτ = m0 + φ0·m1 + k·(l·m1 + n1) + φ0²·m2 + 2φ0·k·(l·m2 + n2) + k²·(l²·m2 + 2l·n2 + o2),
// m0 = ∫A0C0, m1 = ∫(A0C1 + A1C0), n1 = ∫τ(A0C1 + A1C0), m2 = ∫A1C1, n2 = ∫τA1C1,
// o2 = ∫τ²A1C1 (and for α: ∫A0 + φ0·∫A1 + k·(l·∫A1 + ∫τA1)). The six coefficients of
// (1, φ0, k, φ0², 2φ0·k, k²) summed over cells 0 … l − 1 are the band's prefix tables at line l;
// a run of whole cells [lo, hi] is a difference of two records, recentred at c = lo in double
// (φ_c = φ0 + k·lo ∈ [0, 1] and |k|·(hi − lo) ≤ 1, so no term exceeds the result by more than
// the record's size over the run's: the tables' error is ~1e−16 × (hi + lo)², none in practice).
// The partial cells at the run's ends and pieces crossing no line of q take 3-point
// Gauss–Legendre (exact: α·c is quartic along a segment within a cell). A segment so costs
// O(min(p crossings, q crossings)) pieces, each two cell loads and one pair of records.

/// Cell l's moments along a band (the record's layout): corner(b, a, ch) is the raster value
/// (ch: r, g, b, α) at the band's lower (b = 0) or upper (b = 1) p line and q line l + a.
/// e[0 … 2]: α's (∫A0, ∫A1, l·∫A1 + ∫τA1); e[3 + 6·ch …]: colour ch's six coefficients.
template <class Corner>
inline void bandCellMoments(int l, const Corner& corner, double e[kTf2BandMoments]) {
    struct Lin {
        double c0, c1;  // c0 + c1·τ
    };
    const auto across = [&](int ch, Lin& v0, Lin& v1) {  // v0 + φ·v1
        const double a00 = corner(0, 0, ch), a01 = corner(0, 1, ch);
        const double a10 = corner(1, 0, ch), a11 = corner(1, 1, ch);
        v0 = {a00, a01 - a00};
        v1 = {a10 - a00, a11 - a10 - a01 + a00};
    };
    // ∫₀¹ τⁿ f g dτ for linear f, g.
    const auto integral = [](int n, Lin f, Lin g) {
        return f.c0 * g.c0 / (n + 1) + (f.c0 * g.c1 + f.c1 * g.c0) / (n + 2) +
               f.c1 * g.c1 / (n + 3);
    };
    const double L = l;
    Lin a0, a1;
    across(3, a0, a1);
    const Lin one{1.0, 0.0};
    e[0] = integral(0, a0, one);
    e[1] = integral(0, a1, one);
    e[2] = L * e[1] + integral(1, a1, one);
    for (int ch = 0; ch < 3; ++ch) {
        Lin c0, c1;
        across(ch, c0, c1);
        const double m0 = integral(0, a0, c0);
        const double m1 = integral(0, a0, c1) + integral(0, a1, c0);
        const double n1 = integral(1, a0, c1) + integral(1, a1, c0);
        const double m2 = integral(0, a1, c1), n2 = integral(1, a1, c1);
        const double o2 = integral(2, a1, c1);
        double* o = e + 3 + 6 * ch;
        o[0] = m0;
        o[1] = m1;
        o[2] = L * m1 + n1;
        o[3] = m2;
        o[4] = L * m2 + n2;
        o[5] = L * L * m2 + 2.0 * L * n2 + o2;
    }
}

/// A run of whole cells [lo, hi] (q lines) of one band, ready to sum (bandRunSum): its two
/// records (null where the run meets no cell with α > 0), the recentring line c = lo, the cross
/// fraction φ_c there, its slope k, and the factor to the segment's measure.
struct BandRun {
    const double* a = nullptr;
    const double* b = nullptr;
    double c = 0.0, phi = 0.0, k = 0.0, scale = 0.0;
};

/// One lane's run of whole cells [lo, hi] (q lines, lo < hi) of the piece around u = um of the
/// segment p = pa + u·dp, q = qa + u·dq (walking x lines: p = s; else p = t), weight w: the
/// band the piece lies in (φ clamped beyond the domain), the run clipped to the band's cells
/// with α > 0 (Tf2Raster::bandCells).
template <class Real>
UDVR_CPU_GPU inline BandRun bandRunOf(const Tf2Raster<Real>& r, bool walkX, double pa, double qa,
                                      double dp, double dq, double um, int lo, int hi, double w) {
    constexpr int M = kTf2BandMoments;
    const int np = walkX ? r.width : r.height;
    const double pm = pa + um * dp;
    int band;
    BandRun run;  // beyond the domain φ is clamped: constant (k = 0)
    const bool inside = pm > 0.0 && pm < np - 1;
    if (!(pm > 0.0)) {
        band = 0;
    } else if (pm >= np - 1) {
        band = np - 2;
        run.phi = 1.0;
    } else {
        band = static_cast<int>(pm);
        band = band < np - 2 ? band : np - 2;
        run.k = dp / dq;
    }
    const std::size_t n = static_cast<std::size_t>(walkX ? r.height : r.width);
    const std::size_t bandsX = static_cast<std::size_t>(r.width - 1);
    if (r.bandCells) {
        const float* cells = r.bandCells + 2 * ((walkX ? 0 : bandsX) + band);
        const int first = static_cast<int>(cells[0]), end = static_cast<int>(cells[1]);
        lo = lo > first ? lo : first;
        hi = hi < end ? hi : end;
        if (lo >= hi) return run;
    }
    if (inside) {
        run.phi = pa + dp * ((lo - qa) / dq) - band;
        run.phi = run.phi < 0.0 ? 0.0 : (run.phi > 1.0 ? 1.0 : run.phi);
    }
    const std::size_t base = walkX ? 0 : bandsX * static_cast<std::size_t>(r.height);
    run.a = r.bandPrefix + (base + static_cast<std::size_t>(band) * n + lo) * M;
    run.b = run.a + static_cast<std::size_t>(hi - lo) * M;
    run.c = lo;
    run.scale = w / (dq < 0.0 ? -dq : dq);
    return run;
}

/// The run's ∫ of (α·r, α·g, α·b, α) over its q range times run.scale (0 without records).
UDVR_CPU_GPU inline void bandRunSum(const BandRun& run, double out[4]) {
    for (int ch = 0; ch < 4; ++ch) out[ch] = 0.0;
    if (!run.a) return;
    const double *a = run.a, *b = run.b;
    const double c = run.c, phi = run.phi, k = run.k;
    // α: low lines' sum 0 and high lines' sum 0 mean α = 0 on the run (all corners ≥ 0).
    const double d0 = b[0] - a[0], d1 = b[1] - a[1];
    if (d0 == 0.0 && d1 == 0.0) return;
    out[3] = (d0 + phi * d1 + k * ((b[2] - a[2]) - c * d1)) * run.scale;
    for (int ch = 0; ch < 3; ++ch) {
        const double* pa = a + 3 + 6 * ch;
        const double* pb = b + 3 + 6 * ch;
        double d[6];
        for (int m = 0; m < 6; ++m) d[m] = pb[m] - pa[m];
        const double sk = d[2] - c * d[1], spk = d[4] - c * d[3];
        const double skk = d[5] - 2.0 * c * d[4] + c * c * d[3];
        out[ch] = (d[0] + phi * d[1] + k * sk + phi * (phi * d[3] + 2.0 * k * spk) + k * k * skk) *
                  run.scale;
    }
}

/// Adds w × ∫ over u ∈ [ua, ub] of TF2 along (s, t) = (sa + u·ds, ta + u·dt) to out, in the
/// lanes of m, for a piece inside one raster cell (clamped beyond the domain): 3-point
/// Gauss–Legendre, one load of the cell; cells with α = 0 at every corner add nothing.
template <class T, class Real>
UDVR_CPU_GPU UDVR_INLINE void cellPiece(const Tf2Raster<Real>& r, T sa, T ta, T ds, T dt, T ua,
                                        T ub, T w, lanes::MaskOf<T> m, T out[4]) {
    using S = lanes::ScalarOf<T>;
    using I = lanes::IntOf<T>;
    constexpr S kNode = S(0.38729833462074168852), kW0 = S(5.0 / 18.0), kW1 = S(8.0 / 18.0);
    const T len = ub - ua, mid = (ua + ub) * S(0.5);
    I i, j;
    T fx, fy;
    rasterCell(rasterCoordinate<T>(lanes::fma(mid, ds, sa), S(0), S(1), r.width), r.width, i, fx);
    rasterCell(rasterCoordinate<T>(lanes::fma(mid, dt, ta), S(0), S(1), r.height), r.height, j, fy);
    auto use = m;
    if (r.cellEmptyDistance)
        use = m & (rasterLoad<T>(r.cellEmptyDistance, j * (r.width - 1) + i, m) == S(0));
    if (!lanes::anyOf(use)) return;
    const Tf2Cell<T> cell(r, i, j, use);
    T ci, cj;
    if constexpr (lanes::kIsVector<T>) {
        ci = lanes::toFloat(i);
        cj = lanes::toFloat(j);
    } else {
        ci = static_cast<T>(i);
        cj = static_cast<T>(j);
    }
    const T nodes[3] = {mid - kNode * len, mid, mid + kNode * len};
    const S weights[3] = {kW0, kW1, kW0};
    for (int n = 0; n < 3; ++n) {
        const T s = rasterCoordinate<T>(lanes::fma(nodes[n], ds, sa), S(0), S(1), r.width);
        const T t = rasterCoordinate<T>(lanes::fma(nodes[n], dt, ta), S(0), S(1), r.height);
        T v[4];
        cell.at(s - ci, t - cj, v);
        const T wl = lanes::select(use, len * weights[n] * w, T{});
        for (int ch = 0; ch < 3; ++ch) out[ch] = lanes::fma(wl, v[3] * v[ch], out[ch]);
        out[3] = lanes::fma(wl, v[3], out[3]);
    }
}

/// The walk of tf2MeanAlongSegment with r.bandPrefix (see above), over the segments of
/// `source` as segmentWalk.
template <class T, class Real, class Source>
UDVR_CPU_GPU UDVR_INLINE void bandedWalk(const Tf2Raster<Real>& r, Source& source,
                                         lanes::MaskOf<T> live, T out[4]) {
    using S = lanes::ScalarOf<T>;
    using I = lanes::IntOf<T>;
    using M = lanes::MaskOf<T>;
    const S ox = static_cast<S>(r.x0), oy = static_cast<S>(r.y0);
    const S ix = static_cast<S>(r.invDx), iy = static_cast<S>(r.invDy);
    const I nW = I{} + r.width, nH = I{} + r.height;
    T sa{}, ta{}, ds{}, dt{}, uP{}, u0{}, uEnd{}, weight{};
    I lineP{}, stepP{};
    M walkX{};
    constexpr S kInf = std::numeric_limits<S>::infinity(), kMax = std::numeric_limits<S>::max();
    // Narrows [lo, hi] to the u where a + u·d lies in [b0, b1] (not for non-finite a or d: the
    // walk clamps those as before).
    const auto clip = [&](T a, T d, S b0, S b1, T& lo, T& hi) {
        const auto flat = d == S(0), inside = (a >= b0) & (a <= b1);
        const auto ok = (lanes::abs(a) <= kMax) & (lanes::abs(d) <= kMax);
        const T safe = lanes::select(flat, lanes::splat<T>(S(1)), d);
        const T ua = (b0 - a) / safe, ub = (b1 - a) / safe;
        const T inf = lanes::splat<T>(kInf);
        T from = lanes::min(ua, ub), to = lanes::max(ua, ub);
        from = lanes::select(flat, lanes::select(inside, T{} - inf, inf), from);
        to = lanes::select(flat, lanes::select(inside, inf, T{} - inf), to);
        lo = lanes::select(ok, lanes::max(lo, from), lo);
        hi = lanes::select(ok, lanes::min(hi, to), hi);
    };
    // Starts the next segment of the lanes of m that have one (returned).
    const auto begin = [&](M m) {
        T xa{}, ya{}, xb{}, yb{}, w{};
        const M got = source.next(m, xa, ya, xb, yb, w);
        if (!lanes::anyOf(got)) return got;
        const T sa1 = (xa - ox) * ix, ta1 = (ya - oy) * iy;
        const T sb1 = (xb - ox) * ix, tb1 = (yb - oy) * iy;
        sa = lanes::select(got, sa1, sa);
        ta = lanes::select(got, ta1, ta);
        ds = lanes::select(got, sb1 - sa1, ds);
        dt = lanes::select(got, tb1 - ta1, dt);
        weight = lanes::select(got, w, weight);
        // The lines crossed along each axis (within the domain).
        const T nx = lanes::abs(rasterCoordinate<T>(sb1, S(0), S(1), r.width) -
                                rasterCoordinate<T>(sa1, S(0), S(1), r.width));
        const T ny = lanes::abs(rasterCoordinate<T>(tb1, S(0), S(1), r.height) -
                                rasterCoordinate<T>(ta1, S(0), S(1), r.height));
        const M wx = nx <= ny;
        walkX = lanes::select(got, wx, walkX);
        // Only the part inside the box of cells with α > 0 adds (none: u from 1 to 1).
        T from{}, to = lanes::splat<T>(S(1));
        clip(sa1, sb1 - sa1, static_cast<S>(r.opaqueBox[0]), static_cast<S>(r.opaqueBox[1]), from,
             to);
        clip(ta1, tb1 - ta1, static_cast<S>(r.opaqueBox[2]), static_cast<S>(r.opaqueBox[3]), from,
             to);
        const auto none = !(from < to);
        from = lanes::select(none, lanes::splat<T>(S(1)), from);
        to = lanes::select(none, lanes::splat<T>(S(1)), to);
        const T pa = lanes::select(wx, sa1, ta1), dp = lanes::select(wx, sb1 - sa1, tb1 - ta1);
        I lp, sp;
        firstLineN<T>(lanes::fma(from, dp, pa), dp, lanes::select(wx, nW, nH), lp, sp);
        lineP = lanes::select(got, lp, lineP);
        stepP = lanes::select(got, sp, stepP);
        uP = lanes::select(got, lineParameter<T>(pa, dp, lp, sp), uP);
        u0 = lanes::select(got, from, u0);
        uEnd = lanes::select(got, to, uEnd);
        return got;
    };
    for (int ch = 0; ch < 4; ++ch) out[ch] = T{};
    M active = begin(live);
    while (lanes::anyOf(active)) {
        const T u1 = lanes::max(lanes::min(uP, uEnd), u0);
        const T pa = lanes::select(walkX, sa, ta), dp = lanes::select(walkX, ds, dt);
        const T qa = lanes::select(walkX, ta, sa), dq = lanes::select(walkX, dt, ds);
        const I np = lanes::select(walkX, nW, nH), nq = lanes::select(walkX, nH, nW);
        const T q0 = lanes::fma(u0, dq, qa), q1 = lanes::fma(u1, dq, qa);
        // A piece whose q range (clamped) misses its band's cells with α > 0 adds nothing.
        M busy = active;
        if (r.bandCells) {
            const T pm = lanes::fma((u0 + u1) * S(0.5), dp, pa);
            T npf, nqf;
            if constexpr (lanes::kIsVector<T>)
                npf = lanes::toFloat(np), nqf = lanes::toFloat(nq);
            else
                npf = static_cast<T>(np), nqf = static_cast<T>(nq);
            const T pc = lanes::select(pm > S(0), lanes::min(pm, npf - S(1)), T{});
            I band;
            if constexpr (lanes::kIsVector<T>)
                band = lanes::min(lanes::truncToInt(pc), np - 2);
            else
                band = std::min(static_cast<int>(pc), np - 2);
            band = band + lanes::select(walkX, I{}, I{} + (r.width - 1));
            T first, end;
            if constexpr (lanes::kIsVector<T>) {
                lanes::gatherPair(r.bandCells, band * 2, active, first, end);
            } else {
                first = static_cast<T>(r.bandCells[2 * band]);
                end = static_cast<T>(r.bandCells[2 * band + 1]);
            }
            const T top = nqf - S(1);
            const T qLo = lanes::max(lanes::min(lanes::min(q0, q1), top), T{});
            const T qHi = lanes::min(lanes::max(lanes::max(q0, q1), T{}), top);
            const auto below = qHi<first, above = qLo> end;
            busy = active & !(below | above);
        }
        // The q lines inside the piece: the first ahead of its start, the last before its end.
        I l1, st1, l2, st2;
        firstLineN<T>(q0, dq, nq, l1, st1);
        firstLineN<T>(q1, T{} - dq, nq, l2, st2);
        const auto has1 = st1 != 0, has2 = st2 != 0, ordered = (l2 - l1) * st1 >= 0;
        const M inner = busy & has1 & has2 & ordered;
        const T uL1 = lanes::min(lanes::max(lineParameter<T>(qa, dq, l1, st1), u0), u1);
        const T uL2 = lanes::min(lanes::max(lineParameter<T>(qa, dq, l2, st2), uL1), u1);
        if (lanes::anyOf(busy))
            cellPiece<T>(r, sa, ta, ds, dt, u0, lanes::select(inner, uL1, u1), weight, busy, out);
        if (lanes::anyOf(inner)) {
            cellPiece<T>(r, sa, ta, ds, dt, uL2, u1, weight, inner, out);
            const M run = inner & (l1 != l2);
            if (lanes::anyOf(run)) {
                const I lo = lanes::min(l1, l2), hi = lanes::max(l1, l2);
                const T um = (u0 + u1) * S(0.5);
                if constexpr (lanes::kIsVector<T>) {
                    // Each lane's two records requested before any is read (they are far apart
                    // in the tables: the loads' latency, not their count, is what costs).
                    BandRun runs[lanes::kWidth];
                    int laneOf[lanes::kWidth], count = 0;
                    for (std::uint32_t b = lanes::bits(run); b != 0; b &= b - 1) {
                        const int l = std::countr_zero(b);
                        const BandRun one = bandRunOf(r, walkX[l] != 0, pa[l], qa[l], dp[l], dq[l],
                                                      um[l], lo[l], hi[l], weight[l]);
                        if (!one.a) continue;
                        for (int line = 0; line < 3; ++line) {
                            __builtin_prefetch(one.a + 8 * line);
                            __builtin_prefetch(one.b + 8 * line);
                        }
                        runs[count] = one;
                        laneOf[count++] = l;
                    }
                    for (int c = 0; c < count; ++c) {
                        double v[4];
                        bandRunSum(runs[c], v);
                        for (int ch = 0; ch < 4; ++ch)
                            out[ch][laneOf[c]] += static_cast<float>(v[ch]);
                    }
                } else {
                    double v[4];
                    bandRunSum(
                        bandRunOf(r, walkX, static_cast<double>(pa), static_cast<double>(qa),
                                  static_cast<double>(dp), static_cast<double>(dq),
                                  static_cast<double>(um), lo, hi, static_cast<double>(weight)),
                        v);
                    for (int ch = 0; ch < 4; ++ch) out[ch] += static_cast<T>(v[ch]);
                }
            }
        }
        // Past the p line reached at u1; a lane is done at u = 1.
        const auto atP = uP <= u1;
        if constexpr (lanes::kIsVector<T>) {
            lineP = lanes::select(atP, lineP + stepP, lineP);
            stepP = lanes::select(atP & ((lineP < 0) | (lineP > np - 1)), I{}, stepP);
        } else if (atP) {
            lineP += stepP;
            if (lineP < 0 || lineP > np - 1) stepP = 0;
        }
        uP = lanes::select(atP, lineParameter<T>(pa, dp, lineP, stepP), uP);
        u0 = u1;
        const M walked = active;
        active = active & (u0 < uEnd);
        if constexpr (Source::kMany) {
            const M finished = walked & !active;
            if (lanes::anyOf(finished)) {
                if constexpr (Source::kPooled) source.flush(finished, out);
                active = active | begin(finished);
            }
        }
    }
    if constexpr (Source::kPooled) source.collect(out);
}

/// segmentWalk, by runs where r.cellRun is set; bandedWalk where r.bandPrefix is.
template <class T, class Real, class Source>
UDVR_CPU_GPU UDVR_INLINE void segmentWalkOf(const Tf2Raster<Real>& r, Source& source,
                                            lanes::MaskOf<T> live, T out[4]) {
    if (r.bandPrefix)
        bandedWalk<T>(r, source, live, out);
    else if (r.cellRun)
        segmentWalk<true, T>(r, source, live, out);
    else
        segmentWalk<false, T>(r, source, live, out);
}

}  // namespace detail

}  // namespace udvr
