#pragma once
// The exact mean of a raster TF2 along segments by the banded walk (SPEC §9;
// Tf2Raster::bandPrefix): runs of whole cells of one band from the band's prefix tables, the
// partial cells by Gauss–Legendre (bandedWalk), and the per-cell moments the tables hold
// (bandCellMoments). Over T ∈ {double, float, lanes::Vf}.
#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "udvr/classify/tf2_raster.h"
#include "udvr/classify/tf2_walk_lines.h"

namespace udvr::detail {

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
        active = stillWalking<Source, M>(source, active, u0 < uEnd, begin, out);
    }
    if constexpr (Source::kPooled) source.collect(out);
}

}  // namespace udvr::detail
