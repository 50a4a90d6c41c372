#pragma once
// E[TF2(X, G)] for the `uniform` model (SPEC §9): (X, G) = (cx, cy) + Σ_i t_i·(a_i, b_i) with
// t_i ~ U[−1, 1] independent, (a_i, b_i) = h_i·(w_i, u_i) (h_i the voxel's half width, w_i its
// trilinear weight, u_i = n̂·g_i): the paper's bivariate box spline with up to 32 directions.
// Its exact evaluation is exponential in the directions (paper §6), so it is computed by
// conditioning on X:
// - X = Σ a_i t_i over the ≤ 8 corners (a_i ≠ 0) is a univariate box spline, taken exactly
//   (its density from BoxSplineTail);
// - G | X = x is taken as cy + β(x − cx) + R with β = cov(X, G)/var X and R = Σ_i r_i t_i,
//   r_i = b_i − β a_i, independent of X: R is uncorrelated with X, and independent of it where
//   the directions with a_i ≠ 0 are parallel (a sample on a grid point: one corner) or carry
//   none of G. R is a univariate box spline, taken in `uniform-fast`'s form (BoxSplineFast: its
//   two widest boxes exact, the rest a Gaussian with Edgeworth terms);
// - `exactTerms` = 1 first takes the direction of the widest a_i out and integrates over its
//   t exactly (Gauss–Legendre), conditioning only the rest: the normal step then carries the
//   dependence between the remaining corners, which is ~10× smaller (docs/models.md).
// The outer integral over x is detail::tf2ConditionalOuter, the Gaussian's.
#include <algorithm>
#include <cmath>
#include <vector>

#include "udvr/classify/expected_tf.h"
#include "udvr/classify/expected_tf2_gaussian.h"
#include "udvr/reconstruct/box_spline.h"
#include "udvr/util/check.h"

namespace udvr {

/// One direction of the bivariate box spline: t·(a, b), t ~ U[−1, 1]; data units (a: value,
/// b: gradient magnitude).
struct BoxDirection2 {
    double a = 0.0, b = 0.0;
};

namespace detail {
/// R = Σ_i r_i t_i (t_i ~ U[−1, 1]) in BoxSplineFast form, zero mean: boxes of widths 2|r_i| from
/// lo = −Σ|r_i|; the two widest exact, the rest (any number) by its variance and cumulants, as
/// makeBoxSplineFast. Widths are kept ≥ `floor` (> 0).
inline BoxSplineFast<double> residualBoxSpline(const double* r, int n, double floor) {
    BoxSplineFast<double> b;
    double h1 = 0, h2 = 0, r1 = 0, r2 = 0, r4 = 0, r6 = 0, all2 = 0;
    for (int i = 0; i < n; ++i) {
        const double h = 2.0 * std::abs(r[i]);
        b.lo -= 0.5 * h;
        b.total += h;
        all2 += h * h;
        const double up = std::max(h1, h), down = std::min(h1, h), out = std::min(h2, down);
        h2 = std::max(h2, down);
        h1 = up;
        r1 += out;
        r2 += out * out;
        r4 += out * out * out * out;
        r6 += out * out * out * out * out * out;
    }
    b.h1 = std::max(h1, floor);
    b.h2 = std::max(h2, floor);
    b.center = b.lo + 0.5 * r1;
    const double var = std::max(r2 / 12.0, floor * floor);
    b.sigma = std::sqrt(var);
    b.k4 = -r4 / (var * var * 2880.0);
    b.k6 = r6 / (var * var * var * 181440.0);
    b.variance = all2 / 12.0;
    return b;
}

/// E over B = m + R (R of residualBoxSpline) of (α·c, α)(a, B) on the raster's column blend at
/// x = a: along y, α and c are linear between rows, α·c quadratic, so as expectedTfUniformFast,
/// E = E[P_0(B)] (P_0 the quadratic piece at the support's lower end; exact mean and variance)
/// + Σ_{rows u in the support} Σ_d Δ_d·E[(B − u)_+^d] (boxSplineFastTail), Δ_d the jumps of the
/// pieces' coefficients about u. Clamped outside the rows. A support narrower than `point` is
/// the TF2 at the mean.
inline void tf2BoxSplineAlongY(const Tf2Raster<double>& r, double a, double m,
                               const BoxSplineFast<double>& b,
                               const BoxSplineFastScaled<double>& sc, double point, double out[4]) {
    if (!(b.total > point)) {
        tf2At<double>(r, a, m, true, out);
        return;
    }
    const Tf2Axes ax{r, false};
    const int nb = ax.nb();
    double fa = std::clamp((a - ax.a0()) / ax.da(), 0.0, static_cast<double>(ax.na() - 1));
    const int ia = std::min(static_cast<int>(fa), ax.na() - 2);
    fa -= ia;
    const double b0 = ax.b0(), db = ax.db();
    const double lo = m + b.lo, hi = lo + b.total;
    // Rows kLo … kHi inside (lo, hi); the piece at lo is row kLo − 1 … kLo (clamped ends:
    // constant).
    const int kLo = std::clamp(static_cast<int>(std::floor((lo - b0) / db)) + 1, 0, nb);
    const int kHi = std::clamp(static_cast<int>(std::ceil((hi - b0) / db)) - 1, -1, nb - 1);
    for (int ch = 0; ch < 4; ++ch) out[ch] = 0.0;
    if (ax.emptyBetween(ia, std::max(kLo - 1, 0), std::min(kHi + 1, nb - 1))) return;
    const auto row = [&](int k, double v[4]) {  // (c_r, c_g, c_b, α) on row k at a
        for (int ch = 0; ch < 4; ++ch)
            v[ch] = ax.at(ia, k, ch) + fa * (ax.at(ia + 1, k, ch) - ax.at(ia, k, ch));
    };
    // The piece below row k as P(B) = A + B1·(B − y_k) + C·(B − y_k)² per channel (α·c and α).
    const auto piece = [&](int k, double A[4], double B1[4], double C[4]) {
        double v1[4];
        row(std::clamp(k, 0, nb - 1), v1);
        if (k <= 0 || k >= nb) {  // clamped: constant
            for (int ch = 0; ch < 3; ++ch) A[ch] = v1[3] * v1[ch], B1[ch] = C[ch] = 0.0;
            A[3] = v1[3], B1[3] = C[3] = 0.0;
            return;
        }
        double v0[4];
        row(k - 1, v0);
        // On [y_{k−1}, y_k], τ = (B − y_k)/db ∈ [−1, 0]: α = α_k + dα·τ, c = c_k + dc·τ.
        const double da = (v1[3] - v0[3]) / db;
        for (int ch = 0; ch < 3; ++ch) {
            const double dc = (v1[ch] - v0[ch]) / db;
            A[ch] = v1[3] * v1[ch];
            B1[ch] = v1[3] * dc + da * v1[ch];
            C[ch] = da * dc;
        }
        A[3] = v1[3], B1[3] = da, C[3] = 0.0;
    };
    // E[P_0(B)], P_0 the piece under lo (the one ending at row kLo), about y_kLo.
    {
        double A[4], B1[4], C[4];
        piece(kLo, A, B1, C);
        const double yk = b0 + std::min(kLo, nb - 1) * db;
        const double e = m - yk, e2 = e * e + b.variance;
        for (int ch = 0; ch < 4; ++ch) out[ch] = A[ch] + B1[ch] * e + C[ch] * e2;
    }
    for (int k = kLo; k <= kHi; ++k) {
        // At row k: the piece above (k + 1, about y_{k+1}) re-expanded about y_k, minus the one
        // below (k, about y_k).
        double A0[4], B0[4], C0[4], A1[4], B1[4], C1[4];
        piece(k, A0, B0, C0);
        piece(k + 1, A1, B1, C1);
        double t[3];
        const double yk = b0 + k * db;
        boxSplineFastTail(sc, (m + b.center - yk) * sc.invSigma, t);
        const double s1 = b.sigma, s2 = b.sigma * b.sigma;
        for (int ch = 0; ch < 4; ++ch) {
            const double L = -db;  // y_k − y_{k+1}
            const double a1 = A1[ch] + B1[ch] * L + C1[ch] * L * L, b1 = B1[ch] + 2 * C1[ch] * L;
            out[ch] +=
                (a1 - A0[ch]) * t[0] + (b1 - B0[ch]) * s1 * t[1] + (C1[ch] - C0[ch]) * s2 * t[2];
        }
    }
}

/// The conditional evaluation with every direction inside the normal step (exactTerms = 0).
/// Directions with |a| ≤ tinyWidth count for G only; residuals narrower than pointWidth are
/// point masses.
inline void expectedTf2UniformConditional(const Tf2Raster<double>& r, double cx, double cy,
                                          const BoxDirection2* d, int n, double tinyWidth,
                                          double pointWidth, double out[4]) {
    UniformSum x;  // X = shift + Σ h·U[0, 1], h = 2|a| ascending
    double vxx = 0.0, vxy = 0.0, vyy = 0.0;
    x.shift = cx;
    for (int i = 0; i < n; ++i) {
        const double a = std::abs(d[i].a), b = d[i].a < 0 ? -d[i].b : d[i].b;
        vyy += b * b;
        if (!(a > tinyWidth)) continue;
        vxx += a * a;
        vxy += a * b;
        x.shift -= a;
        int k = x.n++;
        if (k >= kMaxUniformTerms) UDVR_FAIL("a uniform sample with more than 8 value terms");
        while (k > 0 && x.h[k - 1] > 2 * a) {
            x.h[k] = x.h[k - 1];
            --k;
        }
        x.h[k] = 2 * a;
    }
    for (int i = 0; i < x.n; ++i) x.total += x.h[i];
    vxx /= 3;  // var(t) = 1/3
    vxy /= 3;
    vyy /= 3;
    const double beta = x.n > 0 ? vxy / vxx : 0.0, s = std::sqrt(std::max(vyy - vxy * beta, 0.0));
    double res[32];
    for (int i = 0; i < n; ++i) {
        const double a = std::abs(d[i].a) > tinyWidth ? d[i].a : 0.0;
        res[i] = d[i].b - beta * a;
    }
    const BoxSplineFast<double> rb = residualBoxSpline(res, n, pointWidth);
    const BoxSplineFastScaled<double> scaled(rb);
    const auto inner = [&](double a, double m, double v[4]) {
        tf2BoxSplineAlongY(r, a, m, rb, scaled, pointWidth, v);
    };
    if (x.n == 0) {  // X is the point cx
        inner(cx, cy, out);
        return;
    }
    // X's density: the widest box over the rest, (P(Y ≥ x − h) − P(Y ≥ x))/h.
    UniformSum rest = x;
    const double hw = rest.h[--rest.n];
    rest.total -= hw;
    const BoxSplineTail tail(rest);
    const auto survival = [&](double z) {  // P(Y ≥ z)
        double t[3];
        tail.at(rest.shift - z, t);
        return t[0];
    };
    std::vector<double> cuts;
    // The density's knots, where its pieces (polynomials of degree n − 1) meet: every vertex sum
    // (≤ 254). Gauss–Legendre between them is then exact for the density; with only the two
    // widest boxes' knots the 1D image was off by 1e−5 for 6–8 boxes.
    for (int mask = 1; mask + 1 < (1 << x.n); ++mask) {
        double v = x.shift;
        for (int k = 0; k < x.n; ++k)
            if (mask & (1 << k)) v += x.h[k];
        cuts.push_back(v);
    }
    tf2ConditionalOuter(
        r, false, x.shift, x.shift + x.total, std::sqrt(vxx), cx, cy, beta, s, cuts,
        [&](double v) { return (survival(v - hw) - survival(v)) / hw; }, inner, 4, out);
}
}  // namespace detail

/// E[(α·c, α)(X, G)] for (X, G) = (cx, cy) + Σ_i t_i·d_i (header comment); exactTerms 0 or 1.
inline void expectedTf2Uniform(const Tf2Raster<double>& r, double cx, double cy,
                               const BoxDirection2* d, int n, int exactTerms, double tinyWidth,
                               double pointWidth, double out[4]) {
    int widest = -1;
    for (int i = 0; i < n; ++i)
        if (std::abs(d[i].a) > tinyWidth &&
            (widest < 0 || std::abs(d[i].a) > std::abs(d[widest].a)))
            widest = i;
    if (exactTerms == 0 || widest < 0) {
        detail::expectedTf2UniformConditional(r, cx, cy, d, n, tinyWidth, pointWidth, out);
        return;
    }
    BoxDirection2 rest[32];
    int m = 0;
    double rxx = 0.0, ryy = 0.0;  // the rest's variances (×3)
    for (int i = 0; i < n; ++i) {
        if (i == widest) continue;
        rest[m++] = d[i];
        rxx += d[i].a * d[i].a;
        ryy += d[i].b * d[i].b;
    }
    const BoxDirection2 w = d[widest];
    // t ∈ [−1, 1]: 8 base pieces, plus, where the rest's spread along an axis is short against
    // w's (the integrand's kinks there smooth out over only that scale), where the centre crosses
    // a raster line of that axis, graded by that scale.
    std::vector<double> cuts;
    for (int k = 0; k <= 8; ++k) cuts.push_back(-1.0 + 0.25 * k);
    const auto crossings = [&](double c, double slope, double origin, double step, int count,
                               double spread) {
        const double width = spread / std::abs(slope);  // t-scale
        if (!(width < 0.25)) return;  // kinks smoothed out over more than a base piece
        const double lo = std::min(c - slope, c + slope), hi = std::max(c - slope, c + slope);
        for (int k = std::max(0, static_cast<int>(std::floor((lo - origin) / step)));
             k <= std::min(count - 1, static_cast<int>(std::ceil((hi - origin) / step))); ++k) {
            const double at = (origin + k * step - c) / slope;
            cuts.push_back(at);
            for (double g : {0.25, 1.0, 4.0})
                for (double sign : {-1.0, 1.0}) cuts.push_back(at + sign * g * width);
        }
    };
    crossings(cx, w.a, r.x0, 1.0 / r.invDx, r.width, std::sqrt(rxx / 3));
    crossings(cy, w.b, r.y0, 1.0 / r.invDy, r.height, std::sqrt(ryy / 3));
    for (double& c : cuts) c = std::clamp(c, -1.0, 1.0);
    std::sort(cuts.begin(), cuts.end());
    static constexpr double kX[4] = {0.1834346424956498, 0.5255324099163290, 0.7966664774136267,
                                     0.9602898564975363};
    static constexpr double kW[4] = {0.3626837833783620, 0.3137066458778873, 0.2223810344533745,
                                     0.1012285362903763};
    for (int ch = 0; ch < 4; ++ch) out[ch] = 0.0;
    for (std::size_t k = 0; k + 1 < cuts.size(); ++k) {
        const double c = 0.5 * (cuts[k] + cuts[k + 1]), h = 0.5 * (cuts[k + 1] - cuts[k]);
        if (!(h > 0)) continue;
        for (int nd = 0; nd < 8; ++nd) {
            const double t = c + (nd < 4 ? -kX[nd % 4] : kX[nd % 4]) * h;
            double v[4];
            detail::expectedTf2UniformConditional(r, cx + t * w.a, cy + t * w.b, rest, m, tinyWidth,
                                                  pointWidth, v);
            const double wt = 0.5 * h * kW[nd % 4];  // the density of t is 1/2
            for (int ch = 0; ch < 4; ++ch) out[ch] += wt * v[ch];
        }
    }
}

}  // namespace udvr
