#pragma once
// The closed form of a raster TF2's mean along a segment inside rows of constant TF2 (SPEC §9;
// Tf2Raster::rowSameUpTo, rowPrefix): rowConstantSegment, and the cell and segment-end records
// it reads. Over T ∈ {double, float, lanes::Vf}.
#include <limits>

#include "udvr/classify/tf2_raster.h"

namespace udvr::detail {

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

}  // namespace udvr::detail
