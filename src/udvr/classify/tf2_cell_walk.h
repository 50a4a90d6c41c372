#pragma once
// The exact mean of a raster TF2 along segments by a walk over the raster lines they cross
// (SPEC §9): per cell, or per run of cells (Tf2Raster::cellRun), the mean of the bilinear α and
// the α·c products in closed form (segmentWalk). Over T ∈ {double, float, lanes::Vf}.
#include <limits>

#include "udvr/classify/tf2_raster.h"
#include "udvr/classify/tf2_walk_lines.h"

namespace udvr::detail {

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

/// Where a walk of the segment (sa, ta) + u·(ds, dt) (raster coordinates; ids = 1/ds,
/// idt = 1/dt) goes on from parameter u at (s, t), in the lanes of m: the next x and y lines
/// ahead, their steps and parameters (by runs, kRuns: the end of the run of cells it is in),
/// u0 = u; the other lanes keep theirs.
template <bool kRuns, class T, class Real>
UDVR_CPU_GPU UDVR_INLINE void linesAhead(const Tf2Raster<Real>& r, lanes::MaskOf<T> m, T u, T s,
                                         T t, T sa, T ta, T ds, T dt, T ids, T idt,
                                         lanes::IntOf<T>& lineX, lanes::IntOf<T>& stepX,
                                         lanes::IntOf<T>& lineY, lanes::IntOf<T>& stepY, T& ux,
                                         T& uy, T& u0) {
    lanes::IntOf<T> lx, sx, ly, sy;
    firstLine<T>(s, ds, r.width, lx, sx);
    firstLine<T>(t, dt, r.height, ly, sy);
    if constexpr (kRuns) lx = runLineAhead<T>(r, lx, sx, bandAhead<T>(t, ly, sy, r.height), m);
    lineX = lanes::select(m, lx, lineX);
    stepX = lanes::select(m, sx, stepX);
    lineY = lanes::select(m, ly, lineY);
    stepY = lanes::select(m, sy, stepY);
    ux = lanes::select(m, lineParameterFrom<T>(sa, ids, lx, sx), ux);
    uy = lanes::select(m, lineParameterFrom<T>(ta, idt, ly, sy), uy);
    u0 = lanes::select(m, u, u0);
}

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
    T sa{}, ta{}, ds{}, dt{}, ids{}, idt{}, ux{}, uy{}, u0{}, weight{};
    I lineX{}, stepX{}, lineY{}, stepY{};
    // The lanes of m go on from segment parameter u, raster position (s, t): the lines ahead.
    const auto goOnFrom = [&](lanes::MaskOf<T> m, T u, T s, T t) {
        detail::linesAhead<kRuns, T>(r, m, u, s, t, sa, ta, ds, dt, ids, idt, lineX, stepX, lineY,
                                     stepY, ux, uy, u0);
    };
    // Starts the next segment of the lanes of m that have one (returned).
    const auto begin = [&](lanes::MaskOf<T> m) {
        if constexpr (Source::kPrepared) {  // the source has the start of each segment's walk
            const lanes::MaskOf<T> got = source.nextPrepared(m, sa, ta, ds, dt, ids, idt, weight,
                                                             lineX, stepX, lineY, stepY, ux, uy);
            u0 = lanes::select(got, T{}, u0);
            return got;
        } else {
            T xa{}, ya{}, xb{}, yb{}, w{};
            const lanes::MaskOf<T> got = source.next(m, xa, ya, xb, yb, w);
            if (!lanes::anyOf(got)) return got;
            // Raster coordinates, unclamped (pieces outside the domain clamp at evaluation).
            const T sa1 = (xa - ox) * ix, ta1 = (ya - oy) * iy;
            sa = lanes::select(got, sa1, sa);
            ta = lanes::select(got, ta1, ta);
            ds = lanes::select(got, (xb - ox) * ix - sa1, ds);
            dt = lanes::select(got, (yb - oy) * iy - ta1, dt);
            ids = lanes::select(got, S(1) / ds, ids);
            idt = lanes::select(got, S(1) / dt, idt);
            weight = lanes::select(got, w, weight);
            goOnFrom(got, T{}, sa1, ta1);
            return got;
        }
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
                const auto leave = [&](I cell, T from, T slope, T inv) {
                    T c;
                    if constexpr (lanes::kIsVector<T>)
                        c = lanes::toFloat(cell);
                    else
                        c = static_cast<T>(cell);
                    const T inf = lanes::splat<T>(std::numeric_limits<S>::infinity());
                    return lanes::select(
                        slope > S(0), (c + d - from) * inv,
                        lanes::select(slope < S(0), (c + S(1) - d - from) * inv, inf));
                };
                uJump = lanes::min(lanes::min(leave(i, sa, ds, ids), leave(j, ta, dt, idt)),
                                   lanes::splat<T>(S(1)));
            }
        }
        if (lanes::anyOf(use)) {
            // One load of the cell's (or its run's) corners serves the three nodes: a cell's
            // two rows of two adjacent points each (gatherRow8 on lanes), a run's four corners.
            I lo = i, hi = i + 1;
            if constexpr (kRuns) detail::runOf<T>(r, i, j, use, lo, hi);
            const Tf2Cell<T> cell = [&] {
                if constexpr (kRuns)
                    return Tf2Cell<T>(r, lo, hi, j, use);
                else
                    return Tf2Cell<T>(r, i, j, use);
            }();
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
        ux = lanes::select(movedX, detail::lineParameterFrom<T>(sa, ids, lineX, stepX), ux);
        uy = lanes::select(atY, detail::lineParameterFrom<T>(ta, idt, lineY, stepY), uy);
        u0 = u1;
        // Only a jump past the piece's end: restarting at a line found an ulp behind would walk
        // the same piece again, forever.
        jump = jump & (uJump > u1);
        if (lanes::anyOf(jump))  // restart the line walk where the segment leaves the block
            goOnFrom(jump, uJump, lanes::fma(uJump, ds, sa), lanes::fma(uJump, dt, ta));
        active =
            detail::stillWalking<Source, lanes::MaskOf<T>>(source, active, u0 < S(1), begin, out);
    }
    if constexpr (Source::kPooled) source.collect(out);
}

}  // namespace udvr::detail
