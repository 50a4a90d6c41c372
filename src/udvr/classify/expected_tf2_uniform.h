#pragma once
// E[TF2(X, G)] for the `uniform` model (SPEC §9): (X, G) = (cx, cy) + Σ_i t_i·(a_i, b_i) with
// t_i ~ U[−1, 1] independent, (a_i, b_i) = h_i·(w_i, u_i) (h_i the voxel's half width, w_i its
// trilinear weight, u_i = n̂·g_i): the paper's bivariate box spline with up to 32 directions.
// `uniform` takes expectedTf2UniformExact (expected_tf2_uniform_exact.h: within 1e−6);
// `uniform-fast`, for rendering, conditions on X:
// - X = Σ a_i t_i over the ≤ 8 corners (a_i ≠ 0) is a univariate box spline, taken exactly
//   (its density from BoxSplineTail);
// - G | X = x is taken as cy + β(x − cx) + R with β = cov(X, G)/var X and R = Σ_i r_i t_i,
//   r_i = b_i − β a_i, independent of X: R is uncorrelated with X, and independent of it where
//   the directions with a_i ≠ 0 are parallel (a sample on a grid point: one corner) or carry
//   none of G. R is a univariate box spline, taken in `uniform-fast`'s form (BoxSplineFast: its
//   two widest boxes exact, the rest a Gaussian with Edgeworth terms). Its error against the
//   exact evaluation: docs/models.md.
// The outer integral over x is detail::tf2ConditionalOuter, the Gaussian's.
#include <algorithm>
#include <cmath>
#include <vector>

#include "udvr/classify/expected_tf.h"
#include "udvr/classify/expected_tf2_gaussian.h"
#include "udvr/classify/expected_tf2_uniform_exact.h"
#include "udvr/reconstruct/box_spline.h"
#include "udvr/util/check.h"

namespace udvr {

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

/// The conditional evaluation (`uniform-fast`).
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

/// E[(α·c, α)(X, G)] for (X, G) = (cx, cy) + Σ_i t_i·d_i: `exact` (the `uniform` model) by
/// expectedTf2UniformExact (error ≤ 1e−6), else (`uniform-fast`) by the conditioning above.
inline void expectedTf2Uniform(const Tf2Raster<double>& r, double cx, double cy,
                               const BoxDirection2* d, int n, bool exact, double tinyWidth,
                               double pointWidth, double out[4]) {
    if (exact) {
        Tf2UniformExactOptions opt;
        expectedTf2UniformExact(r, cx, cy, d, n, tinyWidth, opt, out);
    } else {
        detail::expectedTf2UniformConditional(r, cx, cy, d, n, tinyWidth, pointWidth, out);
    }
}

}  // namespace udvr
