#include "udvr/classify/expected_tf2_gaussian.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "udvr/util/fast_math.h"
#include "udvr/util/lanes.h"
#include "udvr/util/normal_cdf.h"

namespace udvr {

namespace detail {
namespace {
/// The raster seen along axes (A, B): A = x when !swapped, else A = y.
struct Tf2Axes {
    const Tf2Raster<double>& r;
    bool swapped;
    int na() const { return swapped ? r.height : r.width; }
    int nb() const { return swapped ? r.width : r.height; }
    double a0() const { return swapped ? r.y0 : r.x0; }
    double b0() const { return swapped ? r.x0 : r.y0; }
    double da() const { return 1.0 / (swapped ? r.invDy : r.invDx); }
    double db() const { return 1.0 / (swapped ? r.invDx : r.invDy); }
    /// Whether every raster point on A-lines ia, ia + 1 and B-lines kLo … kHi has α = 0, from
    /// the empty cells' Chebyshev distances (false when the raster has none).
    bool emptyBetween(int ia, int kLo, int kHi) const {
        if (!r.cellEmptyDistance) return false;
        const int cLo = std::min(kLo, nb() - 2), cHi = std::max(cLo, std::min(kHi, nb() - 1) - 1);
        const int kc = (cLo + cHi) / 2;
        const int i = swapped ? kc : ia, j = swapped ? ia : kc;
        const float d = r.cellEmptyDistance[static_cast<std::size_t>(j) * (r.width - 1) + i];
        return d > static_cast<float>(std::max(kc - cLo, cHi - kc));
    }
    /// The point on A-line ia and B-line ib: its (r, g, b, α).
    const float* point(int ia, int ib) const {
        const int i = swapped ? ib : ia, j = swapped ? ia : ib;
        return r.rgba + (static_cast<std::size_t>(j) * r.width + i) * 4;
    }
};

/// E over B ~ N(m, s²) of (α·c, α)(a, B), s > 0, B-lines within m ± 8s (outside: the nearest
/// line's value, error < 1e−15).
void tf2NormalAlongB(const Tf2Axes& ax, double a, double m, double s, double out[4]) {
    const int na = ax.na(), nb = ax.nb();
    double fa = (a - ax.a0()) / ax.da();
    fa = std::clamp(fa, 0.0, static_cast<double>(na - 1));
    const int ia = std::min(static_cast<int>(fa), na - 2);
    fa -= ia;
    const double b0 = ax.b0(), db = ax.db();
    // Lines kLo … kHi: the window m ± 8s, clamped to the raster.
    const int kLo = std::clamp(static_cast<int>(std::floor((m - 8 * s - b0) / db)), 0, nb - 1);
    const int kHi = std::clamp(static_cast<int>(std::ceil((m + 8 * s - b0) / db)), 0, nb - 1);
    for (int ch = 0; ch < 4; ++ch) out[ch] = 0.0;
    if (ax.emptyBetween(ia, kLo, kHi)) return;  // α = 0 on every point it would read
    // Φ, 1 − Φ and φ at the lines are computed a chunk at a time, and then the chunk's pieces
    // a register of pieces at a time (independent sums, one horizontal sum per chunk): one
    // piece after the other waited for the last one's sums.
    constexpr int kChunk = 32;
    using V = lanes::VRd;
    constexpr int kW = sizeof(V) / sizeof(double);
    static_assert(kChunk % kW == 0);
    // Index 0: the chunk's first line (the last one of the previous chunk); 1 … count: the next.
    alignas(64) double cdf[kChunk + 1], upper[kChunk + 1], pdf[kChunk + 1], zs[kChunk + 1];
    alignas(64) double val[4][kChunk + 1];  // (c_r, c_g, c_b, α) on the lines at a
    const double invS = 1.0 / s;
    const double t0Lo = (m - (b0 + kLo * db)) / db, e = s / db;
    const auto normals = [&](int first, int count, int at) {  // lines first …, into [at …]
        for (int c = 0; c < count; c += kW) {                 // a register of lines at a time
            V z;
            for (int l = 0; l < kW; ++l) z[l] = (b0 + (first + c + l) * db - m) * invS;
            // 1 − Φ from the tail: keeps its digits
            const NormalAt<V> n = normalAt(z, detail::ExpNonPositiveOf{});
            const V vc = n.cdf, vu = n.upper, vp = n.pdf;
            for (int l = 0; l < kW && c + l < count; ++l) {
                zs[at + c + l] = z[l], cdf[at + c + l] = vc[l];
                upper[at + c + l] = vu[l], pdf[at + c + l] = vp[l];
            }
        }
    };
    const auto line = [&](int k, int at) {  // line k's values at a into val[·][at]
        using F4 = lanes::Vec<float, 4>;
        using D4 = lanes::Vec<double, 4>;
        F4 lo, hi;  // the point's 4 channels on A-lines ia, ia + 1
        std::memcpy(&lo, ax.point(ia, k), sizeof lo);
        std::memcpy(&hi, ax.point(ia + 1, k), sizeof hi);
        const D4 l = __builtin_convertvector(lo, D4), h = __builtin_convertvector(hi, D4);
        const D4 v = l + fa * (h - l);
        for (int ch = 0; ch < 4; ++ch) val[ch][at] = v[ch];
    };
    normals(kLo, 1, 0);
    line(kLo, 0);
    // Below the first line (clamped, or beyond the window): the line's value.
    for (int ch = 0; ch < 3; ++ch) out[ch] += cdf[0] * val[3][0] * val[ch][0];
    out[3] += cdf[0] * val[3][0];
    for (int k0 = kLo; k0 < kHi; k0 += kChunk) {
        const int count = std::min(kChunk, kHi - k0);
        normals(k0 + 1, count, 1);  // lines k0 + 1 … k0 + count
        for (int c = 1; c <= count; ++c) line(k0 + c, c);
        // Piece c (lines k0 + c, k0 + c + 1), c < count; lanes past count add 0 (their
        // moments are taken between a line and itself).
        for (int c = count + 1; c < kChunk + 1; ++c) {
            zs[c] = zs[count], cdf[c] = cdf[count], upper[c] = upper[count], pdf[c] = pdf[count];
            for (int ch = 0; ch < 4; ++ch) val[ch][c] = val[ch][count];
        }
        V acc[4] = {};
        for (int c = 0; c < count; c += kW) {
            const auto at = [](const double* p) {
                V v;
                std::memcpy(&v, p, sizeof v);
                return v;
            };
            const V z0 = at(zs + c), z1 = at(zs + c + 1), p0d = at(pdf + c), p1d = at(pdf + c + 1);
            // ∫ z^p φ over [z0, z1]: M0 (between upper tails where z0 ≥ 0), M1, M2.
            const V m0 =
                z0 >= 0.0 ? at(upper + c) - at(upper + c + 1) : at(cdf + c + 1) - at(cdf + c);
            const V m1 = p0d - p1d;
            const V m2 = m0 + z0 * p0d - z1 * p1d;
            // On the piece, with τ = (B − line k)/db = τ0 + e·z: τ0 = (m − b_k)/db, e = s/db.
            V t0;
            for (int l = 0; l < kW; ++l) t0[l] = t0Lo - (k0 + c + l - kLo);
            const V a0 = at(val[3] + c), da = at(val[3] + c + 1) - a0;
            const V p0 = a0 + da * t0, p1 = da * e;  // α = p0 + p1·z
            for (int ch = 0; ch < 3; ++ch) {
                const V c0 = at(val[ch] + c), dc = at(val[ch] + c + 1) - c0;
                const V q0 = c0 + dc * t0, q1 = dc * e;  // c = q0 + q1·z
                acc[ch] += p0 * q0 * m0 + (p0 * q1 + p1 * q0) * m1 + p1 * q1 * m2;
            }
            acc[3] += p0 * m0 + p1 * m1;
        }
        for (int ch = 0; ch < 4; ++ch)
            for (int l = 0; l < kW; ++l) out[ch] += acc[ch][l];
        // The chunk's last line is the next chunk's first.
        zs[0] = zs[count], cdf[0] = cdf[count], upper[0] = upper[count], pdf[0] = pdf[count];
        for (int ch = 0; ch < 4; ++ch) val[ch][0] = val[ch][count];
    }
    const double up0 = upper[0];
    double v0[4];
    for (int ch = 0; ch < 4; ++ch) v0[ch] = val[ch][0];
    // Above the last line: its value.
    for (int ch = 0; ch < 3; ++ch) out[ch] += up0 * v0[3] * v0[ch];
    out[3] += up0 * v0[3];
}

/// E[(α·c, α)(A, B)] for A with density `pdfA` on [lo, hi] (σ_A = sa) and B | A = a of mean
/// mb + β(a − ma) and standard deviation s, A = x unless `swapped`: the outer integral over a of
/// inner(a, m_B(a), out), E over B | A = a (tf2NormalAlongB for a normal; see the header comment).
/// `cuts` comes in holding where pdfA has kinks or jumps; every σ_A/2, the A-lines and the
/// crossings of m_B(a) with B-lines are added. fewestNodes (2, 4 or 8) bounds the nodes per
/// interval from below: 2 only where the integrand is smooth on the scale σ_A (the Gaussian);
/// a box-spline density of n boxes is a polynomial of degree n − 1 between its knots, which
/// 4 nodes integrate exactly for n ≤ 8.
template <class Pdf, class Inner>
void tf2ConditionalOuter(const Tf2Raster<double>& r, bool swapped, double lo, double hi, double sa,
                         double ma, double mb, double beta, double s, std::vector<double>& cuts,
                         Pdf pdfA, Inner inner, int fewestNodes, double out[4]) {
    const Tf2Axes ax{r, swapped};
    const int steps = static_cast<int>(std::ceil((hi - lo) / (0.5 * sa)));
    for (int k = 0; k <= steps; ++k) cuts.push_back(lo + k * (0.5 * sa));
    const double a0 = ax.a0(), da = ax.da();
    for (int k = std::max(0, static_cast<int>(std::floor((lo - a0) / da)));
         k <= std::min(ax.na() - 1, static_cast<int>(std::ceil((hi - a0) / da))); ++k)
        cuts.push_back(a0 + k * da);
    if (beta != 0.0) {
        const double b0 = ax.b0(), db = ax.db();
        const double bl = std::min(mb + beta * (lo - ma), mb + beta * (hi - ma));
        const double bh = std::max(mb + beta * (lo - ma), mb + beta * (hi - ma));
        const double width = s / std::abs(beta);  // a-scale of the inner function's steepness
        for (int k = std::max(0, static_cast<int>(std::floor((bl - b0) / db)));
             k <= std::min(ax.nb() - 1, static_cast<int>(std::ceil((bh - b0) / db))); ++k) {
            const double at = ma + (b0 + k * db - mb) / beta;
            cuts.push_back(at);
            if (width < 0.5 * sa)
                for (double g : {1.0 / 16, 0.25, 1.0, 4.0})
                    for (double sign : {-1.0, 1.0}) cuts.push_back(at + sign * g * width);
        }
    }
    for (double& c : cuts) c = std::clamp(c, lo, hi);
    std::sort(cuts.begin(), cuts.end());
    // Gauss–Legendre on [−1, 1] with 8 points; on intervals at most a quarter of the
    // integrand's shortest scale (σ_A, and s/|β| where m_B(a) crosses B-lines) long 4 points,
    // and at most an eighth 2 points (n points err by L^(2n+1)·f^(2n)/c_n, c_2 = 4320: at
    // L ≤ scale/8 below ~1e−6 of the interval's mass; 4 points at ≤ scale/4 below 1e−9).
    static constexpr double kX8[4] = {0.1834346424956498, 0.5255324099163290, 0.7966664774136267,
                                      0.9602898564975363};
    static constexpr double kW8[4] = {0.3626837833783620, 0.3137066458778873, 0.2223810344533745,
                                      0.1012285362903763};
    static constexpr double kX4[2] = {0.3399810435848563, 0.8611363115940526};
    static constexpr double kW4[2] = {0.6521451548625461, 0.3478548451374538};
    static constexpr double kX2[1] = {0.5773502691896258};
    static constexpr double kW2[1] = {1.0};
    const double scale = beta != 0.0 ? std::min(sa, s / std::abs(beta)) : sa;
    for (int ch = 0; ch < 4; ++ch) out[ch] = 0.0;
    for (std::size_t k = 0; k + 1 < cuts.size(); ++k) {
        const double c = 0.5 * (cuts[k] + cuts[k + 1]), h = 0.5 * (cuts[k + 1] - cuts[k]);
        if (!(h > 0)) continue;
        const int half = std::max(fewestNodes / 2,
                                  2.0 * h <= 0.125 * scale ? 1 : (2.0 * h <= 0.25 * scale ? 2 : 4));
        const double* xs = half == 1 ? kX2 : (half == 2 ? kX4 : kX8);
        const double* ws = half == 1 ? kW2 : (half == 2 ? kW4 : kW8);
        for (int n = 0; n < 2 * half; ++n) {
            const double x = xs[n % half];
            const double a = c + (n < half ? -x : x) * h;
            const double w = h * ws[n % half] * pdfA(a);
            if (!(w != 0.0)) continue;
            const double m = mb + beta * (a - ma);
            double v[4];
            inner(a, m, v);
            for (int ch = 0; ch < 4; ++ch) out[ch] += w * v[ch];
        }
    }
}
}  // namespace
}  // namespace detail

void expectedTf2Gaussian(const Tf2Raster<double>& r, double mx, double my, double vxx, double vxy,
                         double vyy, double out[4]) {
    vxx = std::max(vxx, 0.0);
    vyy = std::max(vyy, 0.0);
    const double rx = std::sqrt(vxx) * r.invDx, ry = std::sqrt(vyy) * r.invDy;
    if (!(vxx > 0) && !(vyy > 0)) {
        tf2At<double>(r, mx, my, true, out);
        return;
    }
    const bool swapped = !(rx >= ry && vxx > 0);
    const double ma = swapped ? my : mx, mb = swapped ? mx : my;
    const double vaa = swapped ? vyy : vxx, vbb = swapped ? vxx : vyy;
    const double sa = std::sqrt(vaa), beta = vxy / vaa;
    const double s = std::sqrt(std::max(vbb - vxy * beta, 0.0));
    constexpr double kL = 7.0;  // A over m_A ± 7σ_A (mass outside 2.6e−12)
    std::vector<double> cuts;
    detail::tf2ConditionalOuter(
        r, swapped, ma - kL * sa, ma + kL * sa, sa, ma, mb, beta, s, cuts,
        [&](double a) { return normalPdf((a - ma) / sa) / sa; },
        [&, ax = detail::Tf2Axes{r, swapped}](double a, double m, double v[4]) {
            if (s > 1e-13 * ax.db()) {
                detail::tf2NormalAlongB(ax, a, m, s, v);
            } else {  // B is a function of A: the TF2 on the line
                tf2At<double>(r, swapped ? m : a, swapped ? a : m, true, v);
            }
        },
        2, out);  // the integrand is smooth on σ_A: 2 nodes where intervals are that short
}

}  // namespace udvr
