#pragma once
// Uniform reconstruction (SPEC §3; Sakhaee & Entezari 2016): X = Σ_c w_c X_c with independent
// X_c ~ U[lo_c, hi_c] is X = shift + Σ_i h_i U_i, U_i ~ U[0,1], h_i = w_c (hi_c − lo_c): its
// density is a univariate box spline with directions h_i.
//
// Numerics. The textbook evaluation (n-th divided differences of truncated powers over all 2^n
// vertex sums) cancels catastrophically when the widths differ by orders of magnitude, which they
// do near cell faces (trilinear weights → 0). Instead the partial moments
//   T_k(y, d) = E[(y + Z_k)_+^d],  Z_k = h_1 U_1 + … + h_k U_k,  widths ascending,
// are evaluated by the recursion on the largest remaining width
//   T_k(y, d) = (T_{k−1}(y + h_k, d+1) − T_{k−1}(y, d+1)) / ((d+1) h_k),
// which only divides by the largest width of the remaining sum (the values it differences are
// bounded by (k·h_k)^{d+1}, so the absolute error stays ~k^{d+1}·ε·h_k^d), with the closed forms
// T_k = 0 for y ≤ −Σ_{i≤k} h_i and T_k = Σ_j C(d,j) y^{d−j} E[Z_k^j] (all terms ≥ 0) for y ≥ 0.
// Widths ≤ `tinyWidth` are folded into the shift at their mean (error ≤ their width × the TF's
// Lipschitz bound on the mean); exact zeros (w_c = 0 or σ_c = 0) are exact.
#include <cstddef>
#include <utility>

#include "udvr/util/check.h"
#include "udvr/util/lanes.h"

namespace udvr {

inline constexpr int kMaxUniformTerms = 8;

/// X = shift + Σ_{i<n} h[i]·U_i, U_i ~ U[0,1] independent; h ascending, all > 0.
struct UniformSum {
    double shift = 0.0;
    int n = 0;
    double h[kMaxUniformTerms] = {};
    double total = 0.0;  // Σ h = width of the support [shift, shift + total]

    UDVR_CPU_GPU double mean() const { return shift + 0.5 * total; }
    UDVR_CPU_GPU double variance() const {
        double v = 0.0;
        for (int i = 0; i < n; ++i) v += h[i] * h[i];
        return v / 12.0;
    }
};

/// The sum for 8 terms U[lo_c, hi_c] scaled by w_c; widths ≤ tinyWidth go into the shift.
UDVR_CPU_GPU inline UniformSum makeUniformSum(const double lo[8], const double hi[8],
                                              const double w[8], double tinyWidth) {
    UniformSum u;
    for (int c = 0; c < 8; ++c) {
        const double wc = w[c];
        if (wc == 0.0) continue;
        const double width = wc * (hi[c] - lo[c]);
        u.shift += wc * lo[c];
        if (!(width > tinyWidth)) {
            u.shift += 0.5 * width;  // keeps the mean; also absorbs width 0
            continue;
        }
        int i = u.n++;  // insertion sort, ascending
        while (i > 0 && u.h[i - 1] > width) {
            u.h[i] = u.h[i - 1];
            --i;
        }
        u.h[i] = width;
    }
    for (int i = 0; i < u.n; ++i) u.total += u.h[i];
    return u;
}

/// Partial moments of a UniformSum: E[(y + Z)_+^d] for d = 0, 1, 2 with Z = X − shift.
///
/// Evaluated in factorial-scaled form S_k(y, d) = T_k(y, d)/d!, in which the recursion is a plain
/// divided difference, S_k(y, d) = (S_{k−1}(y + h_k, d+1) − S_{k−1}(y, d+1)) / h_k, the closed
/// form for y ≥ 0 is Σ_j m_j · y^{d−j}/(d−j)! with scaled moments m_j = E[Z_k^j]/j!, and the
/// moments convolve without binomials: m_{k,j} = Σ_m m_{k−1,j−m} · h_k^m/(m+1)!. Only the orders
/// a level can need are kept (level k is asked for d ≤ n − k + 2).
class BoxSplineTail {
  public:
    UDVR_CPU_GPU explicit BoxSplineTail(const UniformSum& u) : u_(u) {
        prefix_[0] = 0.0;
        for (int k = 0; k < u.n; ++k) prefix_[k + 1] = prefix_[k] + u.h[k];
        for (int k = 0; k < u.n; ++k) invH_[k] = 1.0 / u.h[k];
        const int jmax0 = u.n + 2;
        for (int j = 0; j <= jmax0; ++j) moment_[0][j] = j == 0 ? 1.0 : 0.0;
        for (int k = 1; k <= u.n; ++k) {
            const double h = u.h[k - 1];
            const int jmax = u.n - k + 2;
            double hp[kMaxUniformTerms + 3];  // h^m/(m+1)!
            hp[0] = 1.0;
            for (int m = 1; m <= jmax; ++m) hp[m] = hp[m - 1] * h * kInvInt[m + 1];
            for (int j = 0; j <= jmax; ++j) {
                double s = 0.0;
                for (int m = 0; m <= j; ++m) s += moment_[k - 1][j - m] * hp[m];
                moment_[k][j] = s;
            }
        }
    }
    /// out[d] = E[(y + Z)_+^d], d = 0, 1, 2 (out[0] = P(Z ≥ −y)).
    UDVR_CPU_GPU void at(double y, double out[3]) const {
        // The level is a template argument (the recursion compiles to plain code): K = n for
        // n < 8, else 8.
        [&]<int... K>(std::integer_sequence<int, K...>) {
            if (!((u_.n == K ? (tail<K>(K, y, out), true) : false) || ...)) tail<8>(8, y, out);
        }
        (std::make_integer_sequence<int, 8>{});
        out[2] *= 2.0;  // S → T: ×d!
    }

  private:
    // out[i] = S_k(y, n − k + i), i = 0, 1, 2, for level k = K (K passed again as `k` for clarity).
    template <int K>
    UDVR_CPU_GPU void tail(int k, double y, double out[3]) const {
        const int d0 = u_.n - k;
        if (y >= 0.0) {
            // y^i/i! for i ≤ d0 + 2, then three dot products with the scaled moments.
            double yp[kMaxUniformTerms + 3];
            yp[0] = 1.0;
            for (int i = 1; i <= d0 + 2; ++i) yp[i] = yp[i - 1] * y * kInvInt[i];
            const double* m = moment_[k];
            for (int i = 0; i < 3; ++i) {
                const int d = d0 + i;
                double s = 0.0;
                for (int j = 0; j <= d; ++j) s += m[j] * yp[d - j];
                out[i] = s;
            }
            return;
        }
        if constexpr (K == 0) {
            out[0] = out[1] = out[2] = 0.0;
        } else {
            if (y + prefix_[K] <= 0.0) {
                out[0] = out[1] = out[2] = 0.0;
                return;
            }
            double a[3], b[3];
            tail<K - 1>(K - 1, y + u_.h[K - 1], a);
            tail<K - 1>(K - 1, y, b);
            const double inv = invH_[K - 1];
            for (int i = 0; i < 3; ++i) out[i] = (a[i] - b[i]) * inv;
        }
    }

    static constexpr double kInvInt[kMaxUniformTerms + 3] = {
        0.0, 1.0, 1.0 / 2, 1.0 / 3, 1.0 / 4, 1.0 / 5, 1.0 / 6, 1.0 / 7, 1.0 / 8, 1.0 / 9, 1.0 / 10};

    const UniformSum& u_;
    double prefix_[kMaxUniformTerms + 1];
    double invH_[kMaxUniformTerms];
    double moment_[kMaxUniformTerms + 1][kMaxUniformTerms + 3];  // E[Z_k^j]/j!
};

/// The box spline's fast form (issue 12): X = center + h1·U1 + h2·U2 + R with the two widest
/// boxes h1 ≥ h2 kept exact and the other terms (≤ 6) as R, zero mean, taken as a Gaussian of
/// their variance σ² with corrections for their fourth and sixth cumulants κ4 = −Σ h⁴/120,
/// κ6 = Σ h⁶/252 (Sakhaee & Entezari's box spline for two directions, the central limit for the
/// rest; the density's series in classify/expected_tf.h, BoxSplineFastScaled). Written over T
/// (double, float, lanes::Vf). Data units.
template <class T>
struct BoxSplineFast {
    T lo{};      // left end of the support [lo, lo + total]
    T total{};   // Σ h
    T center{};  // lo + mean of the remainder: X − center = h1·U1 + h2·U2 + R
    T h1{}, h2{};
    T sigma{};     // remainder's standard deviation (≥ h2/1000)
    T k4{};        // κ4/(24σ⁴) of the remainder, in [−0.05, 0]
    T k6{};        // κ6/(720σ⁶) of the remainder, ≥ 0
    T variance{};  // of X, exact: Σ h²/12
};

/// The fast form of Σ_c w_c U[lo_c, hi_c]; h1, h2 and σ are floored (h1 ≥ floor/1000, each
/// next ≥ 1/1000 of the one above; `floor` > 0, data units) so that no division meets 0
/// (callers treat sums with total ≤ floor as point masses).
template <class T>
UDVR_CPU_GPU UDVR_INLINE BoxSplineFast<T> makeBoxSplineFast(const T lo[8], const T hi[8],
                                                            const T w[8],
                                                            lanes::ScalarOf<T> floor) {
    using lanes::max;
    using lanes::min;
    BoxSplineFast<T> b;
    T h1{}, h2{}, r1{}, r2{}, r4{}, r6{}, all2{};
    for (int c = 0; c < 8; ++c) {
        const T h = max(w[c] * (hi[c] - lo[c]), T{});
        b.lo = lanes::fma(w[c], lo[c], b.lo);
        b.total += h;
        all2 = lanes::fma(h, h, all2);
        // Keep the two widest; the one pushed out joins the remainder (sums of its powers).
        const T up = max(h1, h), down = min(h1, h);
        const T out = min(h2, down);
        h2 = max(h2, down);
        h1 = up;
        const T o2 = out * out;
        r1 += out;
        r2 += o2;
        r4 = lanes::fma(o2, o2, r4);
        r6 = lanes::fma(o2 * o2, o2, r6);
    }
    // Floors, so that nothing divides by 0, each relative to the box above it: h1 ≥ floor/1000
    // (only sums of total ≤ floor, the callers' point masses, have h1 < floor/8), h2 ≥ h1/1000,
    // σ ≥ h2/1000. They add at most 1e−6 of X's variance, and z = t/σ stays below ~1e7 (float
    // keeps its relative precision, z⁴ in range). Absolute floors (h1, h2, σ ≥ floor) spread
    // sums a few floors wide: 0.2 off against a step inside a support of 8e−6 with floors of
    // 6e−6 (uniform_fast_test.cpp).
    const auto s = [](double x) { return lanes::splat<T>(static_cast<lanes::ScalarOf<T>>(x)); };
    b.h1 = max(h1, s(1e-3 * floor));
    b.h2 = max(h2, b.h1 * s(1e-3));
    // The floors widen the boxes about their left ends: the centre moves left by half of what
    // they add, so that the fast form keeps X's mean (E[TF] adds the tail terms to the first
    // piece's polynomial at the exact mean: a mean off by half the second box's floor of 6e−6
    // cost 1e−3 against a TF whose first piece is steep).
    const T added = (b.h1 - h1) + (b.h2 - h2);
    b.center = lanes::fma(r1 - added, s(0.5), b.lo);
    const T sf = b.h2 * s(1e-3);
    const T var = max(r2 * s(1.0 / 12.0), sf * sf);
    b.sigma = lanes::sqrt(var);
    // One power of 1/var at a time: var² and var³ underflow in float where σ is at its floor
    // (0/0 where the remainder is empty); r4 ≤ r2², r6 ≤ r2³ keep the products bounded.
    const T inv = s(1.0) / var;
    b.k4 = -(r4 * inv) * (inv * s(1.0 / 2880.0));           // −(Σh⁴/120)/(24σ⁴)
    b.k6 = ((r6 * inv) * inv) * (inv * s(1.0 / 181440.0));  // (Σh⁶/252)/(720σ⁶)
    b.variance = all2 * s(1.0 / 12.0);
    return b;
}

}  // namespace udvr
