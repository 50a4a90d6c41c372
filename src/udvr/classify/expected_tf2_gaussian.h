#pragma once
// E[TF2(X, G)] for (X, G) bivariate normal (SPEC §9 `gaussian`), in double. By conditioning:
// with A the variable spreading over more raster cells and B the other, B | A = a is normal,
// N(m_B + β(a − m_A), s²) with β = cov/var_A and s² = var_B − cov²/var_A. At a fixed a the TF2
// along B is, between two raster lines of B, α and c linear, α·c quadratic, so E[TF2(a, B)] is
// a closed form in Φ and φ at those lines (as the 1D Gaussian expectation); the outer integral
// over a is Gauss–Legendre on intervals split at every raster line of A (where the integrand
// has kinks), at the a where m_B(a) crosses a line of B ± graded multiples of s/|β| (where it
// turns steep when s is small) and every σ_A/2, over m_A ± 7σ_A (mass outside 2.6e−12).
// Accuracy: the outer integrand is smooth on each interval, which is at most σ_A/2 long;
// measured against an independent dense quadrature in the tests.
#include "udvr/classify/expected_tf2.h"

namespace udvr {

/// A bivariate normal of (X, G): means and covariance (data units).
struct Normal2 {
    double mx = 0.0, mg = 0.0, vxx = 0.0, vxg = 0.0, vgg = 0.0;
};

/// E[(α·c, α)(X, Y)] for (X, Y) ~ N((mx, my), [[vxx, vxy], [vxy, vyy]]) over a raster TF2.
void expectedTf2Gaussian(const Tf2Raster<double>& r, double mx, double my, double vxx, double vxy,
                         double vyy, double out[4]);

}  // namespace udvr
