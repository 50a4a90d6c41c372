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

#include "udvr/reconstruct/trilinear.h"

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
                                              const float w[8], double tinyWidth) {
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
class BoxSplineTail {
  public:
    UDVR_CPU_GPU explicit BoxSplineTail(const UniformSum& u) : u_(u) {
        // Raw moments E[Z_k^j] of the partial sums, j ≤ n+2, by moment convolution with
        // E[(hU)^m] = h^m/(m+1).
        for (int a = 0; a < kMaxUniformTerms + 3; ++a)
            for (int b = 0; b <= a; ++b)
                binom_[a][b] = (b == 0 || b == a) ? 1.0 : binom_[a - 1][b - 1] + binom_[a - 1][b];
        prefix_[0] = 0.0;
        for (int k = 0; k < u.n; ++k) prefix_[k + 1] = prefix_[k] + u.h[k];
        const int jmax = u.n + 2;
        for (int j = 0; j <= jmax; ++j) moment_[0][j] = j == 0 ? 1.0 : 0.0;
        for (int k = 1; k <= u.n; ++k) {
            const double h = u.h[k - 1];
            for (int j = 0; j <= jmax; ++j) {
                double s = 0.0, hp = 1.0;  // Σ_m C(j,m) E[Z_{k−1}^{j−m}] h^m/(m+1)
                for (int m = 0; m <= j; ++m) {
                    s += binomial(j, m) * moment_[k - 1][j - m] * hp / (m + 1);
                    hp *= h;
                }
                moment_[k][j] = s;
            }
        }
    }
    /// out[d] = E[(y + Z)_+^d], d = 0, 1, 2 (out[0] = P(Z ≥ −y)).
    UDVR_CPU_GPU void at(double y, double out[3]) const { tail(u_.n, y, out); }

  private:
    // C(n, k) for n ≤ kMaxUniformTerms + 2 from Pascal's triangle, built once per sum.
    UDVR_CPU_GPU double binomial(int n, int k) const { return binom_[n][k]; }
    // out[i] = T_k(y, n − k + i), i = 0, 1, 2.
    UDVR_CPU_GPU void tail(int k, double y, double out[3]) const {
        const int d0 = u_.n - k;
        if (y >= 0.0) {
            for (int i = 0; i < 3; ++i) {
                const int d = d0 + i;
                double s = 0.0, yp = 1.0;  // Σ_j C(d,j) y^{d−j} E[Z^j], summed from j = d down
                for (int j = d; j >= 0; --j) {
                    s += binomial(d, j) * yp * moment_[k][j];
                    yp *= y;
                }
                out[i] = s;
            }
            return;
        }
        if (y + prefix_[k] <= 0.0 || k == 0) {
            out[0] = out[1] = out[2] = 0.0;
            return;
        }
        const double h = u_.h[k - 1];
        double a[3], b[3];
        tail(k - 1, y + h, a);
        tail(k - 1, y, b);
        for (int i = 0; i < 3; ++i) out[i] = (a[i] - b[i]) / ((d0 + i + 1) * h);
    }

    const UniformSum& u_;
    double prefix_[kMaxUniformTerms + 1];
    double moment_[kMaxUniformTerms + 1][kMaxUniformTerms + 3];
    double binom_[kMaxUniformTerms + 3][kMaxUniformTerms + 3];
};

}  // namespace udvr
