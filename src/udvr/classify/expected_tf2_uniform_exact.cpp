#include "udvr/classify/expected_tf2_uniform_exact.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <optional>
#include <utility>
#include <vector>

namespace udvr {

namespace detail {
namespace {
using Cplx = std::complex<double>;

/// J_d = ∫_{s1}^{s2} s^d e^{i(φ + ρ s)} ds, d = 0, 1, 2: Gauss–Legendre, 6 nodes on pieces whose
/// phase changes by ≤ 1 rad (≤ 5 pieces), or by parts where the phase turns more than 4 rad.
void powerPhaseIntegrals(double s1, double s2, double phi, double rho, Cplx J[3]) {
    static constexpr double kX[3] = {0.2386191860831969, 0.6612093864662645, 0.9324695142031521};
    static constexpr double kW[3] = {0.4679139345726910, 0.3607615730481386, 0.1713244923791704};
    J[0] = J[1] = J[2] = 0.0;
    const double len = s2 - s1;
    if (!(len != 0.0)) return;
    if (std::abs(rho * len) > 4.0) {  // by parts on [0, len], then shifted by s1
        const Cplx e = std::polar(1.0, rho * len), inv = Cplx(0.0, -1.0 / rho);  // 1/(iρ)
        const Cplx K0 = (e - 1.0) * inv, K1 = (len * e - K0) * inv,
                   K2 = (len * len * e - 2.0 * K1) * inv;
        const Cplx base = std::polar(1.0, phi + rho * s1);
        J[0] = base * K0;
        J[1] = base * (K1 + s1 * K0);
        J[2] = base * (K2 + 2.0 * s1 * K1 + s1 * s1 * K0);
        return;
    }
    const int pieces = 1 + static_cast<int>(std::abs(rho * len));
    const double h = len / pieces;
    // e^{iθ} at the nodes by rotation: the first piece's centre, then one step per piece.
    Cplx base = std::polar(1.0, phi + rho * (s1 + 0.5 * h));
    const Cplx step = std::polar(1.0, rho * h);  // |ρh| ≤ 1: the pieces' rule above
    Cplx off[3];
    for (int n = 0; n < 3; ++n) off[n] = std::polar(0.5 * h * kW[n], rho * kX[n] * 0.5 * h);
    for (int q = 0; q < pieces; ++q, base *= step) {
        const double c = s1 + (q + 0.5) * h;
        for (int n = 0; n < 6; ++n) {
            const double s = c + (n < 3 ? -kX[n] : kX[n - 3]) * 0.5 * h;
            const Cplx e = base * (n < 3 ? std::conj(off[n]) : off[n - 3]);
            J[0] += e;
            J[1] += e * s;
            J[2] += e * (s * s);
        }
    }
}

double sincOf(double z) { return std::abs(z) < 1e-4 ? 1.0 - z * z / 6.0 : std::sin(z) / z; }

/// P ← P convolved with the box u ∈ [−a, a] (density 1/(2a)) carrying the phase e^{−iωmu},
/// binned onto the nodes q·dx by the 3-node kernel K(u/dx − q): K(t) = 5/6 − t² for |t| ≤ 1/2,
/// (t² − 3|t| + 13/6)/2 for 1/2 < |t| ≤ 3/2. For every u it keeps the mass (Σ_q K = 1) and the
/// mean (Σ_q q·dx·K = u) and adds exactly dx²/6 to the second moment, so the binned box has
/// var X = a²/3 + dx²/6 and cov(X, G) = ab/3 however narrow it is (cloud-in-cell gives a box
/// narrower than dx about a·dx/2 instead). W_q = ∫ K(u/dx − q) e^{−iωmu} du/(2a), exact (the
/// kernel is quadratic on 3 pieces); nodes whose kernel lies inside the box have
/// W_q = c·z^q (z = e^{−iωm·dx}), summed by a running sum. Returns kw (the result's nodes are
/// lo − kw … hi + kw).
int binBox(double a, double m, double om, double dx, std::vector<Cplx>& P, int lo, int hi,
           std::vector<Cplx>& W, std::vector<Cplx>& Pn) {
    const double ta = a / dx, rho = -om * m * dx;
    const int kw = static_cast<int>(std::ceil(ta + 1.5)) - 1;
    const int qa = static_cast<int>(std::ceil(1.5 - ta)), qb = -qa;  // kernel inside the box
    // ∫_{t1}^{t2} K(t) e^{i(φ + ρt)} dt over K's pieces, t clipped to [t1, t2].
    static constexpr double kPiece[3][5] = {// t from, t to, K = k0 + k1 t + k2 t²
                                            {-1.5, -0.5, 13.0 / 12, 1.5, 0.5},
                                            {-0.5, 0.5, 5.0 / 6, 0.0, -1.0},
                                            {0.5, 1.5, 13.0 / 12, -1.5, 0.5}};
    const auto kernelIntegral = [&](double t1, double t2, double phi) {
        Cplx w = 0.0, J[3];
        for (const auto& pc : kPiece) {
            const double s1 = std::max(t1, pc[0]), s2 = std::min(t2, pc[1]);
            if (!(s2 > s1)) continue;
            powerPhaseIntegrals(s1, s2, phi, rho, J);
            w += pc[2] * J[0] + pc[3] * J[1] + pc[4] * J[2];
        }
        return w * (dx / (2.0 * a));
    };
    W.assign(2 * kw + 1, 0.0);
    for (int q = -kw; q <= kw; ++q)
        if (q < qa || q > qb) W[q + kw] = kernelIntegral(-ta - q, ta - q, rho * q);
    std::fill(Pn.begin() + (lo - kw), Pn.begin() + (hi + kw + 1), Cplx(0.0));
    for (int q = -kw; q <= kw; ++q) {
        if (q >= qa && q <= qb) continue;
        for (int j = lo; j <= hi; ++j) Pn[j + q] += W[q + kw] * P[j];
    }
    if (qa <= qb) {
        const Cplx c = kernelIntegral(-1.5, 1.5, 0.0);
        const Cplx z = std::polar(1.0, rho), za = std::polar(1.0, rho * qa),
                   zb = std::polar(1.0, rho * (qb + 1));
        const auto at = [&](int j) { return j >= lo && j <= hi ? P[j] : Cplx(0.0); };
        Cplx S = 0.0;  // Σ_{q=qa}^{qb} z^q P[j − q]
        for (int j = lo + qa; j <= hi + qb; ++j) {
            S = z * S + za * at(j - qa) - zb * at(j - 1 - qb);
            Pn[j] += c * S;
        }
    }
    std::swap(P, Pn);
    return kw;
}

/// The TF2's columns as functions of g over the window, in pieces on which every column's α
/// and c are linear (only the pieces with α ≠ 0 somewhere are kept); per column strip s (x between
/// columns s and s + 1; s = −1 and s = W − 1 the clamped outsides) the coefficients of
/// Q_{s,ch,p}(g) = Σ_d coef·σ^d (σ from the piece's start) with T = Σ_p f^p Q_p: α: Q0 = α_s, Q1 =
/// Δα; α·c: Q0 = α_s c_s, Q1 = α_s Δc + Δα c_s, Q2 = Δα Δc.
struct Tf2ColumnPieces {
    struct Piece {
        double off = 0, len = 0;  // [g0 + off, g0 + off + len)
        double ya = 0, yb = 0;    // the columns are evaluated at these two ends
    };
    static constexpr std::size_t kMaxStored = 1 << 15;  // coefficient sets kept (36 doubles each)
    const Tf2Raster<double>& r;
    std::vector<Piece> pieces;
    double g0 = 0, support = 0, L = 0;      // the window in g (expectedTf2UniformOnGrid)
    int sLo = 0, sHi = 0;                   // strips sLo … sHi
    std::vector<std::pair<int, int>> live;  // (strip − sLo, piece) where α is not 0 throughout
    std::vector<double> coef;               // [live entry][ch·3 + p][d], if ≤ kMaxStored entries

    Tf2ColumnPieces(const Tf2Raster<double>& rIn, double g0In, double supportIn, double LIn,
                    int sLoIn, int sHiIn)
        : r(rIn), g0(g0In), support(supportIn), L(LIn), sLo(sLoIn), sHi(sHiIn) {
        const double dy = 1.0 / r.invDy;
        // Piece ends in g: the window's edges and the rows inside the support, then the margin.
        std::vector<double> ends{0.0};
        const int j0 = std::max(0, static_cast<int>(std::ceil((g0 - r.y0) * r.invDy)));
        for (int j = j0; j < r.height; ++j) {
            const double o = r.y0 + j * dy - g0;
            if (o >= support) break;
            if (o > 0) ends.push_back(o);
        }
        ends.push_back(support);
        for (std::size_t q = 0; q + 1 < ends.size(); ++q)
            if (ends[q + 1] > ends[q])
                pieces.push_back({ends[q], ends[q + 1] - ends[q], g0 + ends[q], g0 + ends[q + 1]});
        if (pieces.empty())  // G a point: T̃ constant at cy (L = len = 1, only k = 0)
            pieces.push_back({0.0, L, g0 + 0.5 * L, g0 + 0.5 * L});
        else if (L > support)  // margin: α, c linear from the support's top back to its bottom
            pieces.push_back({support, L - support, g0 + support, g0});
        // Each (strip, piece) filled once: kept while at most kMaxStored are live, after that
        // only listed (transforms then fills them again per term).
        const int np = static_cast<int>(pieces.size());
        double e[36];
        for (int s = 0; s <= sHi - sLo; ++s)
            for (int q = 0; q < np; ++q) {
                if (!fill(s, q, e)) continue;
                live.emplace_back(s, q);
                if (live.size() <= kMaxStored) coef.insert(coef.end(), e, e + 36);
            }
        if (live.size() > kMaxStored) coef = {};
    }
    /// Whether these pieces serve a grid of the same window (g0, support, L) over strips sLo …
    /// sHi (a wider range of strips serves too: the strips outside the grid's add nothing).
    bool covers(double g0In, double supportIn, double LIn, int sLoIn, int sHiIn) const {
        return g0 == g0In && support == supportIn && L == LIn && sLo <= sLoIn && sHi >= sHiIn;
    }

    /// The coefficients of strip sLo + s on piece q; false where α = 0 throughout (all 0).
    bool fill(int s, int q, double e[36]) const {
        const auto column = [&](int i, double y, double v[4]) {  // (c, α) of column i at y
            double fy = std::clamp((y - r.y0) * r.invDy, 0.0, static_cast<double>(r.height - 1));
            const int j = std::min(static_cast<int>(fy), r.height - 2);
            fy -= j;
            const float* p0 = r.rgba + 4 * (static_cast<std::size_t>(j) * r.width + i);
            const float* p1 = p0 + 4 * r.width;
            for (int ch = 0; ch < 4; ++ch) v[ch] = p0[ch] + fy * (p1[ch] - p0[ch]);
        };
        const int strip = sLo + s;
        const int i0 = std::clamp(strip, 0, r.width - 1),
                  i1 = std::clamp(strip + 1, 0, r.width - 1);
        const bool flat = strip < 0 || strip >= r.width - 1;  // clamped: constant in x
        const Piece& pc = pieces[q];
        double a0[4], a1[4], b0[4], b1[4];  // columns i0, i1 at the piece's ends
        column(i0, pc.ya, a0);
        column(i0, pc.yb, a1);
        column(flat ? i0 : i1, pc.ya, b0);
        column(flat ? i0 : i1, pc.yb, b1);
        for (int f = 0; f < 36; ++f) e[f] = 0.0;
        if (a0[3] == 0 && a1[3] == 0 && b0[3] == 0 && b1[3] == 0) return false;
        const double inv = 1.0 / pc.len;
        // Column i0: α = A + A'σ, c = C + C'σ; Δ(·) = column i1 − column i0.
        const double A = a0[3], As = (a1[3] - a0[3]) * inv;
        const double dA = b0[3] - a0[3], dAs = (b1[3] - a1[3] - (b0[3] - a0[3])) * inv;
        for (int ch = 0; ch < 3; ++ch) {
            const double C = a0[ch], Cs = (a1[ch] - a0[ch]) * inv;
            const double dC = b0[ch] - a0[ch], dCs = (b1[ch] - a1[ch] - (b0[ch] - a0[ch])) * inv;
            double* c = e + ch * 9;
            c[0] = A * C, c[1] = A * Cs + As * C, c[2] = As * Cs;
            c[3] = A * dC + dA * C;
            c[4] = A * dCs + As * dC + dA * Cs + dAs * C;
            c[5] = As * dCs + dAs * Cs;
            c[6] = dA * dC, c[7] = dA * dCs + dAs * dC, c[8] = dAs * dCs;
        }
        double* c = e + 27;
        c[0] = A, c[1] = As, c[3] = dA, c[4] = dAs;
        return true;
    }

    /// Q̂[(s − sLo)·12 + ch·3 + p] = ∫ Q_{s,ch,p}(g) e^{−iω(g − g0)} dg over the window.
    void transforms(double omega, std::vector<Cplx>& Q) const {
        const int np = static_cast<int>(pieces.size());
        std::vector<Cplx> J(3 * np);
        for (int q = 0; q < np; ++q)
            powerPhaseIntegrals(0.0, pieces[q].len, -omega * pieces[q].off, -omega, &J[3 * q]);
        Q.assign(static_cast<std::size_t>(sHi - sLo + 1) * 12, 0.0);
        double tmp[36];
        for (std::size_t i = 0; i < live.size(); ++i) {
            const auto [s, q] = live[i];
            const double* e = coef.empty() ? (fill(s, q, tmp), tmp) : &coef[36 * i];
            const Cplx* j = &J[3 * q];
            for (int f = 0; f < 12; ++f)
                Q[s * 12 + f] += e[3 * f] * j[0] + e[3 * f + 1] * j[1] + e[3 * f + 2] * j[2];
        }
    }
};

/// expectedTf2UniformExact on one node grid (xCells across the binned corners); returns whether
/// there were binned corners (else the result does not depend on xCells).
bool expectedTf2UniformOnGrid(const Tf2Raster<double>& r, double cx, double cy,
                              const BoxDirection2* d, int n, double tinyWidth, int xCells,
                              Tf2UniformExactOptions& opt, std::optional<Tf2ColumnPieces>& shared,
                              double out[4]) {
    // Corners (a ≠ 0): the widest w apart; the rest binned. y-only: R.
    int widest = -1;
    std::vector<BoxDirection2> corners;
    std::vector<double> yOnly;
    double B = 0.0, A = 0.0;  // Σ|b| over all, Σ|a| over the binned corners
    double tinyA = 0.0;       // Σ|a| over the y-only ones (≤ tinyWidth each, or NaN)
    for (int i = 0; i < n; ++i) {
        B += std::abs(d[i].b);
        if (!(std::abs(d[i].a) > tinyWidth)) {
            tinyA += std::abs(d[i].a);  // NaN stays NaN: data, not a y-only direction
            yOnly.push_back(d[i].b);
        } else if (widest < 0 || std::abs(d[i].a) > std::abs(d[widest].a)) {
            if (widest >= 0) corners.push_back(d[widest]);
            widest = i;
        } else {
            corners.push_back(d[i]);
        }
    }
    for (const BoxDirection2& c : corners) A += std::abs(c.a);
    double BR = 0.0;
    for (const double b : yOnly) BR += std::abs(b);
    if (!std::isfinite(cx + cy + A + B + tinyA + (widest >= 0 ? d[widest].a : 0.0))) {  // NaN/inf
        tf2At<double>(r, cx, cy, true, out);  // (the raster lookup maps NaN to the origin)
        return false;
    }
    if (corners.empty() && !(BR > 0)) {  // a segment or a point: the exact segment mean
        const BoxDirection2 w = widest >= 0 ? d[widest] : BoxDirection2{};
        tf2MeanAlongSegment<double>(r, cx - w.a, cy - w.b, cx + w.a, cy + w.b, true, out);
        return false;
    }
    const double aw = widest >= 0 ? std::abs(d[widest].a) : 0.0;
    const double mw = widest >= 0 ? d[widest].b / d[widest].a : 0.0;
    // Nodes x_j = cx + j·dx, |j| ≤ H: the binned corners' support plus 1.5 nodes per binning.
    const double dx = A > 0 ? 2.0 * A / std::max(xCells, 2) : 0.0;
    const int H =
        A > 0 ? static_cast<int>(std::ceil(A / dx)) + 2 * static_cast<int>(corners.size()) + 1 : 0;
    const int N = 2 * H + 1;
    // The window in g; G a point (B = 0): one piece, k = 0 only.
    const double g0 = B > 0 ? cy - B : cy - 0.5, support = 2.0 * B, L = B > 0 ? 3.0 * B : 1.0;
    // Strips met by x ∈ [xL, xR].
    const double xL = cx - H * dx - aw, xR = cx + H * dx + aw, sx = 1.0 / r.invDx;
    const auto stripOf = [&](double x) {
        return std::clamp(static_cast<int>(std::floor((x - r.x0) * r.invDx)), -1, r.width - 1);
    };
    const int sLo = stripOf(xL), sHi = stripOf(xR);
    // The column pieces depend on the window and the strips only: the coarse grid (called
    // first, with the wider range of strips) builds them and the fine grid reuses them.
    if (!shared || !shared->covers(g0, support, L, sLo, sHi))
        shared.emplace(r, g0, support, L, sLo, sHi);
    const Tf2ColumnPieces& cols = *shared;
    const auto stripStart = [&](int s) { return s < 0 ? xL : std::max(xL, r.x0 + s * sx); };

    std::vector<Cplx> P(N), Pn(N), Q, cum(sHi - sLo + 2), W;
    std::vector<Cplx> lam(4 * N);
    for (int ch = 0; ch < 4; ++ch) out[ch] = 0.0;
    int quiet = 0;
    const int kEnd = B > 0 ? opt.kMax : 0;
    int k = 0;
    for (; k <= kEnd; ++k) {
        const double om = 2.0 * M_PI * k / L;
        // P_j: the point (cx, cy), the binned corners, R.
        std::fill(P.begin(), P.end(), Cplx(0.0));
        P[H] = std::polar(1.0, -om * (cy - g0));
        for (const double b : yOnly) P[H] *= detail::sincOf(b * om);
        int lo = H, hi = H;  // P's nonzero nodes
        for (const BoxDirection2& c : corners) {
            const int kw = detail::binBox(std::abs(c.a), c.b / c.a, om, dx, P, lo, hi, W, Pn);
            lo -= kw;
            hi += kw;
        }
        // Λ_j: T̂ at the nodes, averaged over the widest corner with its phase.
        cols.transforms(om, Q);
        const auto partial = [&](int s, double x1, double x2, Cplx v[4]) {
            // ∫_{x1}^{x2} T̂(x) e^{iω mw (x − cx)} dx inside strip s.
            const double xs = r.x0 + s * sx;
            Cplx J[3];
            detail::powerPhaseIntegrals(x1 - xs, x2 - xs, om * mw * (xs - cx), om * mw, J);
            const double f1 = r.invDx, f2 = r.invDx * r.invDx;
            const Cplx* q = &Q[(s - cols.sLo) * 12];
            for (int ch = 0; ch < 4; ++ch)
                v[ch] =
                    q[ch * 3] * J[0] + q[ch * 3 + 1] * (J[1] * f1) + q[ch * 3 + 2] * (J[2] * f2);
        };
        if (widest >= 0 && aw < sx) {
            // Half-width under a strip's: Λ_j over the ≤ 3 strips it meets, in u = x − x_j, so the
            // segment keeps its length 2·aw to the last digit however large |cx| is (the
            // difference of cumulative integrals at x_j ± aw would lose ulp(x_j)/aw of it).
            for (int j = lo; j <= hi; ++j) {
                const double off = (j - H) * dx, xj = cx + off;
                const int s0 = stripOf(xj - aw), s1 = stripOf(xj + aw);
                for (int ch = 0; ch < 4; ++ch) lam[4 * j + ch] = 0.0;
                for (int s = s0; s <= s1; ++s) {
                    // The strip's start and end in u; each column's position by one expression,
                    // so that the strips' pieces tile [−aw, aw] without a gap.
                    const double xs = r.x0 + s * sx;
                    const double u0 = s > s0 ? std::clamp(xs - cx - off, -aw, aw) : -aw;
                    const double u1 =
                        s < s1 ? std::clamp(r.x0 + (s + 1) * sx - cx - off, -aw, aw) : aw;
                    Cplx J[3];
                    detail::powerPhaseIntegrals(u0, u1, 0.0, om * mw, J);
                    // T̂(x_j + u) = Σ_p q_p f^p, f = f0 + u/sx: as a quadratic in u.
                    const double f0 = (cx - xs + off) * r.invDx, f1 = r.invDx;
                    const Cplx* q = &Q[(s - cols.sLo) * 12];
                    for (int ch = 0; ch < 4; ++ch) {
                        const Cplx q0 = q[ch * 3], q1 = q[ch * 3 + 1], q2 = q[ch * 3 + 2];
                        lam[4 * j + ch] +=
                            ((q0 + f0 * (q1 + f0 * q2)) * J[0] + (q1 + 2.0 * f0 * q2) * f1 * J[1] +
                             q2 * f1 * f1 * J[2]) /
                            (2.0 * aw);
                    }
                }
            }
        } else if (widest >= 0) {
            // cum[s − sLo] = ∫_{xL}^{start of strip s}, per channel (4 × strips).
            cum.assign(4 * (sHi - sLo + 2), 0.0);
            for (int s = sLo; s <= sHi; ++s) {
                Cplx v[4];
                partial(s, stripStart(s), s < sHi ? r.x0 + (s + 1) * sx : xR, v);
                for (int ch = 0; ch < 4; ++ch)
                    cum[4 * (s - sLo + 1) + ch] = cum[4 * (s - sLo) + ch] + v[ch];
            }
            const auto C = [&](double x, Cplx v[4]) {
                const int s = stripOf(x);
                partial(s, stripStart(s), x, v);
                for (int ch = 0; ch < 4; ++ch) v[ch] += cum[4 * (s - sLo) + ch];
            };
            // The phase e^{−iω·mw·(x_j − cx)}/(2aw) by rotation from node lo (one step a node:
            // ≤ 2·H ulps of drift, ~1e−13).
            Cplx ph = std::polar(1.0 / (2.0 * aw), -om * mw * ((lo - H) * dx));
            const Cplx step = std::polar(1.0, -om * mw * dx);
            for (int j = lo; j <= hi; ++j, ph *= step) {
                const double xj = cx + (j - H) * dx;
                Cplx c1[4], c0[4];
                C(xj + aw, c1);
                C(xj - aw, c0);
                for (int ch = 0; ch < 4; ++ch) lam[4 * j + ch] = ph * (c1[ch] - c0[ch]);
            }
        } else {  // X the point cx
            const int s = stripOf(cx);
            const double f = s < 0 || s >= r.width - 1 ? 0.0 : (cx - (r.x0 + s * sx)) * r.invDx;
            const Cplx* q = &Q[(s - cols.sLo) * 12];
            for (int ch = 0; ch < 4; ++ch)
                lam[4 * H + ch] = q[ch * 3] + f * (q[ch * 3 + 1] + f * q[ch * 3 + 2]);
        }
        double big = 0.0;
        for (int ch = 0; ch < 4; ++ch) {
            Cplx t = 0.0;
            for (int j = lo; j <= hi; ++j) t += std::conj(P[j]) * lam[4 * j + ch];
            const double term = (k == 0 ? 1.0 : 2.0) * t.real() / L;
            out[ch] += term;
            big = std::max(big, std::abs(t) * 2.0 / L);
        }
        quiet = big < opt.kTol ? quiet + 1 : 0;
        if (quiet >= opt.kQuiet) break;
    }
    opt.kUsed = std::max(opt.kUsed, std::min(k, kEnd));
    return A > 0;
}
}  // namespace
}  // namespace detail

void expectedTf2UniformExact(const Tf2Raster<double>& r, double cx, double cy,
                             const BoxDirection2* d, int n, double tinyWidth,
                             Tf2UniformExactOptions& opt, double out[4]) {
    opt.kUsed = 0;
    opt.refinement = 0.0;
    // The coarse grid first: its wider strip range lets the fine grid share its column pieces.
    std::optional<detail::Tf2ColumnPieces> cols;
    double coarse[4];
    if (!detail::expectedTf2UniformOnGrid(r, cx, cy, d, n, tinyWidth, opt.xCells, opt, cols,
                                          coarse)) {
        for (int ch = 0; ch < 4; ++ch) out[ch] = coarse[ch];  // no binned corners: no grid
        return;
    }
    detail::expectedTf2UniformOnGrid(r, cx, cy, d, n, tinyWidth, 2 * opt.xCells, opt, cols, out);
    for (int ch = 0; ch < 4; ++ch) {
        opt.refinement = std::max(opt.refinement, std::abs(out[ch] - coarse[ch]));
        out[ch] += (out[ch] - coarse[ch]) / 3.0;
    }
}

void expectedTf2UniformRefined(const Tf2Raster<double>& r, double cx, double cy,
                               const BoxDirection2* d, int n, double tinyWidth, double out[4]) {
    // expectedTf2UniformExact's pair of grids (cells, 2·cells) and extrapolation, the pair moved
    // one doubling on while its refinement is over the threshold: each step evaluates only the
    // new finer grid (and the column pieces are shared by all).
    Tf2UniformExactOptions opt = kUniform2DFast;
    std::optional<detail::Tf2ColumnPieces> cols;
    double coarse[4];
    if (!detail::expectedTf2UniformOnGrid(r, cx, cy, d, n, tinyWidth, opt.xCells, opt, cols,
                                          coarse)) {
        for (int ch = 0; ch < 4; ++ch) out[ch] = coarse[ch];  // no binned corners: no grid
        return;
    }
    for (int cells = opt.xCells;; cells *= 2) {
        double fine[4], refinement = 0.0;
        detail::expectedTf2UniformOnGrid(r, cx, cy, d, n, tinyWidth, 2 * cells, opt, cols, fine);
        for (int ch = 0; ch < 4; ++ch) {
            refinement = std::max(refinement, std::abs(fine[ch] - coarse[ch]));
            out[ch] = fine[ch] + (fine[ch] - coarse[ch]) / 3.0;
            coarse[ch] = fine[ch];
        }
        if (!(refinement > kUniform2DRefineOver) || cells >= kUniform2DMaxCells) return;
    }
}

}  // namespace udvr
