#pragma once
// E[TF2] along the quantile models' polylines (SPEC §9 quantile-range and its populations):
// Σ_j mass_j × the TF2's exact mean along segment j (tf2_segment_walk.h), one polyline at a time
// for scalars, as a pool of the batch's segments for lanes (PooledPolylineSegments).
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>

#include "udvr/classify/tf2_segment_walk.h"

namespace udvr {

/// The most vertices of a polyline expectedTf2QuantileRange takes (quantile levels + 1).
inline constexpr int kMaxPolylineVertices = 128;

namespace detail {
/// The segments j = 1 … count − 1 of a polyline through the vertices (x[j], g[j]), weights
/// mass[j], skipping those whose bit is set in `skip` (taken by the closed form), in turn: the
/// source of expectedTf2QuantileRange's walk for a scalar T (lanes take PooledPolylineSegments).
template <class T>
struct PolylineSegments {
    static_assert(!lanes::kIsVector<T>);
    static constexpr bool kMany = true, kPooled = false, kPrepared = false;
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
/// After prepare() the pool also holds where each item's walk starts (segmentWalk's begin,
/// computed for 16 items at a time), which nextPrepared hands to the lanes that want one by
/// expanding loads, in place of per-lane gathers and line searches each time a lane finishes.
/// Lane vectors only.
template <bool kParts>
struct PooledPolylineSegments {
    static constexpr bool kMany = true, kPooled = true, kPrepared = true;
    using Vf = lanes::Vf;
    using Vi = lanes::Vi;
    static constexpr int kCapacity = lanes::kWidth * kMaxPolylineVertices;
    const Vf* x;
    const Vf* g;
    const float* mass;
    int items = 0, taken = 0;
    std::int16_t itemLane[kCapacity];  // polyline of each item
    std::int16_t itemSeg[kCapacity];   // its segment
    float itemU0[kCapacity];  // its part [u0, u1] of the segment: the part inside the raster's
    float itemU1[kCapacity];  // opaqueBox, and with kParts a piece of that
    std::int32_t laneOf[lanes::kWidth] = {};  // each lane's polyline
    float total[4][lanes::kWidth] = {};       // Σ weight × mean, per polyline
    // With prepare(), per item in hand-out order (padded for the expanding loads), as floats:
    // the segment (or part) in raster coordinates sa + u·ds, ta + u·dt with 1/ds, 1/dt, its
    // weight, the parameters of the x and y lines ahead of u = 0 (linesAhead); then integers:
    // those lines and their steps, and the item's polyline.
    static constexpr int kReals = 9, kInts = 5;
    static constexpr int kPadded = kCapacity + lanes::kWidth;
    float prepared[kReals + kInts][kPadded];

    /// `r`: the raster walked; its opaqueBox trims each segment to the part where α may be
    /// > 0 (exact: the parts outside add 0 to the mean, whose weight keeps the whole length);
    /// a segment with no such part is left out.
    template <class Real>
    PooledPolylineSegments(const Vf* xs, const Vf* gs, const float* m, int count, lanes::Vi skip,
                           lanes::Mask live, const Tf2Raster<Real>& r)
        : x(xs), g(gs), mass(m) {
        const float ox = static_cast<float>(r.x0), oy = static_cast<float>(r.y0);
        const float invDx = static_cast<float>(r.invDx), invDy = static_cast<float>(r.invDy);
        const float box[4] = {
            static_cast<float>(r.opaqueBox[0]), static_cast<float>(r.opaqueBox[1]),
            static_cast<float>(r.opaqueBox[2]), static_cast<float>(r.opaqueBox[3])};
        // [lo, hi] ∩= the parameters u ∈ [0, 1] where a + u·d ∈ [b0, b1] (d = 0: all or none).
        const auto clip = [](float a, float d, float b0, float b1, float& lo, float& hi) {
            if (d != 0.0f) {
                const float u0 = (b0 - a) / d, u1 = (b1 - a) / d;
                lo = std::max(lo, std::min(u0, u1));
                hi = std::min(hi, std::max(u0, u1));
            } else if (!(a >= b0 && a <= b1)) {
                hi = -1.0f;
            }
        };
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
                const float sa = (x[j - 1][l] - ox) * invDx, ta = (g[j - 1][l] - oy) * invDy;
                const float ds = (x[j][l] - ox) * invDx - sa, dt = (g[j][l] - oy) * invDy - ta;
                float lo = 0.0f, hi = 1.0f;
                if (std::isfinite(sa + ds + ta + dt)) {  // else the walk's own handling
                    clip(sa, ds, box[0], box[1], lo, hi);
                    clip(ta, dt, box[2], box[3], lo, hi);
                    if (!(hi > lo)) continue;  // no part inside: adds 0
                }
                const float n = (std::fabs(ds) + std::fabs(dt)) * (hi - lo);
                itemU0[items] = lo;
                itemU1[items] = hi;
                if constexpr (kParts) lines[items] = n;
                cls[items] = static_cast<std::uint8_t>(classOf(n));
                ++start[cls[items] + 1];
                itemLane[items] = static_cast<std::int16_t>(l);
                itemSeg[items] = static_cast<std::int16_t>(j);
                ++items;
            }
        }
        std::int16_t lane[kCapacity], seg[kCapacity];
        float partU0[kCapacity], partU1[kCapacity];
        if constexpr (!kParts) {
            for (int c = 0; c < kClasses; ++c) start[c + 1] += start[c];
            for (int i = 0; i < items; ++i) {
                const int to = start[cls[i]]++;
                lane[to] = itemLane[i];
                seg[to] = itemSeg[i];
                partU0[to] = itemU0[i];
                partU1[to] = itemU1[i];
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
                const float lo = itemU0[i], hi = itemU1[i];
                const float step = (hi - lo) / static_cast<float>(parts[i]);
                for (int p = 0; p < parts[i]; ++p) {
                    const int to = start[cls[i]]++;
                    lane[to] = itemLane[i];
                    seg[to] = itemSeg[i];
                    partU0[to] = p == 0 ? lo : lo + static_cast<float>(p) * step;
                    partU1[to] = p + 1 == parts[i] ? hi : lo + static_cast<float>(p + 1) * step;
                }
            }
        }
        items = start[kClasses];
        std::memcpy(itemLane, lane, sizeof(std::int16_t) * static_cast<std::size_t>(items));
        std::memcpy(itemSeg, seg, sizeof(std::int16_t) * static_cast<std::size_t>(items));
        std::memcpy(itemU0, partU0, sizeof(float) * static_cast<std::size_t>(items));
        std::memcpy(itemU1, partU1, sizeof(float) * static_cast<std::size_t>(items));
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
        float u0[lanes::kWidth] = {}, u1[lanes::kWidth] = {};
        for (int item = first; got != 0; got &= got - 1, ++item) {
            const int l = std::countr_zero(got);
            u0[l] = itemU0[item];
            u1[l] = itemU1[item];
        }
        toParts(lanes::load(u0), lanes::load(u1), xa, ya, xb, yb, w);
        return gotMask;
    }
    /// Part [a, b] of the segments from (xa, ya) to (xb, yb), weight w: its ends and weight.
    static void toParts(Vf a, Vf b, Vf& xa, Vf& ya, Vf& xb, Vf& yb, Vf& w) {
        // A whole segment (u0 = 0, u1 = 1) keeps its vertices.
        const Vf x0 = xa, y0 = ya;
        const Vf dx = xb - x0, dy = yb - y0;
        xa = lanes::select(a == 0.0f, x0, lanes::fma(a, dx, x0));
        ya = lanes::select(a == 0.0f, y0, lanes::fma(a, dy, y0));
        xb = lanes::select(b == 1.0f, xb, lanes::fma(b, dx, x0));
        yb = lanes::select(b == 1.0f, yb, lanes::fma(b, dy, y0));
        w = w * (b - a);
    }
    /// Where each item's walk starts (segmentWalk<kRuns>'s begin), 16 items at a time: the
    /// same values begin computes from next()'s segments.
    template <bool kRuns, class Real>
    void prepare(const Tf2Raster<Real>& r) {
        const float ox = static_cast<float>(r.x0), oy = static_cast<float>(r.y0);
        const float ix = static_cast<float>(r.invDx), iy = static_cast<float>(r.invDy);
        for (int first = 0; first < items; first += lanes::kWidth) {
            const int n = std::min(lanes::kWidth, items - first);
            const lanes::Mask m = lanes::firstLanes(n);
            std::int32_t lane[lanes::kWidth] = {}, seg[lanes::kWidth];
            float u0[lanes::kWidth] = {}, u1[lanes::kWidth] = {};
            for (int k = 0; k < lanes::kWidth; ++k) {
                seg[k] = 1;
                if (k >= n) continue;
                lane[k] = itemLane[first + k];
                seg[k] = itemSeg[first + k];
                u0[k] = itemU0[first + k], u1[k] = itemU1[first + k];
            }
            const Vi polyline = lanes::load(lane), j = lanes::load(seg);
            const auto at = [&](const Vf* v, Vi k) {
                return lanes::gather(reinterpret_cast<const float*>(v),
                                     k * lanes::kWidth + polyline, m);
            };
            Vf xa = at(x, j - 1), ya = at(g, j - 1), xb = at(x, j), yb = at(g, j);
            Vf w = lanes::gather(mass, j, m);
            toParts(lanes::load(u0), lanes::load(u1), xa, ya, xb, yb, w);
            const Vf sa = (xa - ox) * ix, ta = (ya - oy) * iy;
            const Vf ds = (xb - ox) * ix - sa, dt = (yb - oy) * iy - ta;
            const Vf ids = 1.0f / ds, idt = 1.0f / dt;
            Vi lineX{}, stepX{}, lineY{}, stepY{};
            Vf ux{}, uy{}, start{};
            linesAhead<kRuns, Vf>(r, m, Vf{}, sa, ta, sa, ta, ds, dt, ids, idt, lineX, stepX, lineY,
                                  stepY, ux, uy, start);
            const Vf reals[kReals] = {sa, ta, ds, dt, ids, idt, w, ux, uy};
            const Vi ints[kInts] = {lineX, stepX, lineY, stepY, polyline};
            for (int f = 0; f < kReals; ++f) lanes::store(prepared[f] + first, reals[f]);
            for (int f = 0; f < kInts; ++f)  // exact: |values| ≤ the raster's size
                lanes::store(prepared[kReals + f] + first, lanes::toFloat(ints[f]));
        }
    }
    /// The next prepared items to the lanes of m, as many as are left, in order (returned);
    /// the other lanes keep their values.
    lanes::Mask nextPrepared(lanes::Mask m, Vf& sa, Vf& ta, Vf& ds, Vf& dt, Vf& ids, Vf& idt, Vf& w,
                             Vi& lineX, Vi& stepX, Vi& lineY, Vi& stepY, Vf& ux, Vf& uy) {
        std::uint32_t want = lanes::bits(m);
        for (int extra = std::popcount(want) - (items - taken); extra > 0; --extra)
            want &= ~(1u << (31 - std::countl_zero(want)));  // the last lanes get none
        if (want == 0) return lanes::fromBits(0);
        const lanes::Mask got = lanes::fromBits(want);
        Vf* const reals[kReals] = {&sa, &ta, &ds, &dt, &ids, &idt, &w, &ux, &uy};
        for (int f = 0; f < kReals; ++f)
            *reals[f] = lanes::expandFirst(prepared[f] + taken, got, *reals[f]);
        Vi polyline = lanes::load(laneOf);
        Vi* const ints[kInts] = {&lineX, &stepX, &lineY, &stepY, &polyline};
        for (int f = 0; f < kInts; ++f) {
            const Vf v = lanes::expandFirst(prepared[kReals + f] + taken, got, Vf{});
            *ints[f] = lanes::select(got, lanes::truncToInt(v), *ints[f]);
        }
        lanes::store(laneOf, polyline);
        taken += std::popcount(want);
        return got;
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
    const auto walkPool = [&](auto& pool) {
        if (!r.bandPrefix) {  // segmentWalk, which starts its segments from the prepared items
            if (r.cellRun)
                pool.template prepare<true>(r);
            else
                pool.template prepare<false>(r);
        }
        segmentWalkOf<lanes::Vf>(r, pool, lanes::allTrue<lanes::Vf>(), out);
    };
    if (pooledWalkCuts(walk, count)) {
        PooledPolylineSegments<true> pool(x, g, mass, count, skip, walk, r);
        walkPool(pool);
    } else {
        PooledPolylineSegments<false> pool(x, g, mass, count, skip, walk, r);
        walkPool(pool);
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
    // Segments in a box of cells with α = 0 add 0: not walked (up to 32 segments, as above).
    if (r.cellOpaqueSum && count <= 32 && lanes::anyOf(walk)) {
        for (int j = 1; j < count; ++j) {
            const lanes::MaskOf<T> empty =
                tf2SegmentCellsEmpty<T>(r, x[j - 1], g[j - 1], x[j], g[j], walk);
            skip = skip | lanes::select(empty, I{} + (1 << j), I{});
        }
        const int every = static_cast<int>(count == 32 ? ~1u : (1u << count) - 2u);
        walk = walk & !((skip & every) == every);  // lanes with no segment left to walk
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
