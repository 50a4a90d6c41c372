#pragma once
// E[(α·c, α)(X, G)] for the `uniform` model with a 2D TF (SPEC §9), convergent to the exact
// value: (X, G) = (cx, cy) + Σ_i t_i·(a_i, b_i), t_i ~ U[−1, 1] independent, up to 32
// directions (the ≤ 8 corners carry a_i ≠ 0, the others only b_i).
//
// Method: x in real space, g in Fourier. Over a window [g0, g0 + L) holding G's support
// [cy − B, cy + B] (B = Σ|b_i|) the TF2 is replaced by T̃, equal to it on the support and
// continued continuously (α and c linear) across the margin, so T̃ is periodic and C0 in g.
// With ω_k = 2πk/L, T̂_k(x) = ∫ T̃(x, g) e^{−iω_k(g − g0)} dg and P(x, ω) = E[δ(X − x)
// e^{−iω(G − g0)}]:
//   E = (1/L) Σ_{k∈Z} ∫ conj(P(x, ω_k)) T̂_k(x) dx = (1/L) Re[term_0 + 2 Σ_{k≥1} term_k].
// - The directions with a_i = 0 (R, up to 31) enter P exactly as Π sinc(b_i ω): no table.
// - The corners other than the widest are convolved on a grid of nodes x_j = cx + j·Δx
//   (Δx = 2A'/xCells, A' = Σ|a_i| over them), each box's measure e^{−iω m u} du/(2|a|),
//   u ∈ [−|a|, |a|], m = b/a, binned onto the nodes by a 3-node quadratic kernel that keeps
//   every point's mass and mean and adds exactly Δx²/6 to its second moment (binBox), whatever
//   the box's width: the shear in g is an exact phase; the binning errs by O(Δx²).
// - The widest corner is integrated exactly per node: Λ_j = (1/2|a|) ∫ T̂_k(x_j + u) e^{iωmu} du,
//   from the cumulative integral over the raster's column strips (T̂ is Σ_p f^p Q̂_{s,p} in strip
//   s, f its fraction, Q̂ the exact transforms of the column products, piecewise quadratic in g);
//   a corner of half-width under a strip's directly over the ≤ 3 strips it meets, in u (exact
//   length 2|a| however large |cx| is: 1e−9 at cx = 1000 keeps 1e−11 of E, the cumulative way
//   5e−6).
// - Every integral of a polynomial (degree ≤ 2) times e^{iθ} is 6-point Gauss–Legendre on
//   pieces of ≤ 1 rad, or by parts where the phase turns > 4 rad: exact to ~1e−15.
// - No binned corner and R = 0: (X, G) lies on a segment; its exact mean (tf2MeanAlongSegment).
// Errors: the binning's O(Δx²) (each binning adds Δx²/6 to the variance of X, for a box of any
// width: E is off by Δx²/6 × E[∂²T/∂x²]/2 per box plus O(Δx³)), extrapolated away from two
// grids (Richardson; a TF2 quadratic in x comes out exact), and the series' tail (terms decay
// as the sincs of R and of the corners times T̂'s 1/k²; stopped after 8 terms below 1e−11).
// Bound: 1e−6 absolute; grids 2× finer with the series to 1e−13 change the defaults' result by
// ≤ 2.3e−9 in the tests; corners of |a| = 0.003 (weight ~1e−3, beside a voxel face, narrower
// than Δx) beside wide ones: 9e−13 off the closed form (docs/models.md). Until 2026-11-28 the
// binning was cloud-in-cell: a box narrower than Δx got var X ≈ |a|·Δx/2, first order in Δx,
// which Richardson left (7.6e−6 in that case).
// Cost: two grids × the terms × (nodes + strips × row pieces); a few ms to 0.1 s a sample.
#include "udvr/classify/expected_tf2.h"

namespace udvr {

/// One direction of the bivariate box spline: t·(a, b), t ~ U[−1, 1]; data units (a: value,
/// b: gradient magnitude).
struct BoxDirection2 {
    double a = 0.0, b = 0.0;
};

/// The law of (cx, cg) + Σ_i t_i·d_i, t_i ~ U[−1, 1] independent (the bivariate box spline of
/// SPEC §9's uniform model); directions with |a| ≤ tinyWidth are taken as G-only.
struct BoxSpline2 {
    double cx = 0.0, cg = 0.0;
    int n = 0;
    BoxDirection2 d[32];
    double tinyWidth = 0.0;
};

/// Accuracy controls of expectedTf2UniformExact (defaults: error ≤ 1e−6, docs/models.md).
struct Tf2UniformExactOptions {
    int xCells = 384;  // nodes across the non-widest corners' support (Δx = 2A'/xCells; also 2×)
    double kTol = 1e-11;  // stop the series after kQuiet terms each below kTol (absolute)
    int kQuiet = 8;
    int kMax = 1 << 15;       // hard cap on the series
    int kUsed = 0;            // out: the most terms taken
    double refinement = 0.0;  // out: max |E(Δx/2) − E(Δx)| before extrapolation
};

/// Coarser settings (32 node cells, the series to 1e−5, 2 quiet terms): measured max 1.8e−4
/// from the converged value over random rough rasters, ~11× cheaper (docs/models.md). The fast
/// `uniform`'s fallback where its columns do not apply (Tf2BlurTables::boxSpline) and its
/// evaluation without tables.
inline constexpr Tf2UniformExactOptions kUniform2DFast{32, 1e-5, 2};

/// expectedTf2UniformExact at the kUniform2DFast settings, its node cells doubled while its own
/// check says the grid is too coarse (opt.refinement over kUniform2DRefineOver), up to
/// kUniform2DMaxCells. Corners nearly proportional in (a, b) (G almost a function of X) leave a
/// thin sliver that 32 cells miss: random such box splines were up to 2.6e−2 off at 32 cells and
/// within 1.8e−4 after refining (2026-12-05), at ~10–30× the coarse cost there; real data rarely
/// asks (tangle, golden model: no sample; tooth: 6 of 193 fallbacks of a 32² frame). The fast
/// `uniform`'s evaluation where its columns do not apply.
inline constexpr double kUniform2DRefineOver = 2e-4;
inline constexpr int kUniform2DMaxCells = 512;
void expectedTf2UniformRefined(const Tf2Raster<double>& r, double cx, double cy,
                               const BoxDirection2* d, int n, double tinyWidth, double out[4]);

/// E[(α·c, α)(X, G)] for (X, G) = (cx, cy) + Σ_i t_i·d_i (header comment). Directions with
/// |a| ≤ tinyWidth count for G only. out = (E[α·c_r], E[α·c_g], E[α·c_b], E[α]). The binning's
/// O(Δx²) error is extrapolated away (Richardson: (4·E(Δx/2) − E(Δx))/3, its remainder
/// O(Δx³) at the TF's kinks); opt.refinement gets max |E(Δx/2) − E(Δx)|.
void expectedTf2UniformExact(const Tf2Raster<double>& r, double cx, double cy,
                             const BoxDirection2* d, int n, double tinyWidth,
                             Tf2UniformExactOptions& opt, double out[4]);

}  // namespace udvr
