#pragma once
// Fast E[TF2(X, G)] for (X, G) bivariate normal (the 2D `gaussian`) and for the bivariate box
// spline (the 2D `uniform`), from per-TF2 prefiltered rasters (issue 33).
//
// Tables: the TF2's (α·c, α) (α and c bilinear, so α·c is biquadratic on each cell) convolved
// exactly with the axis-aligned Gaussians N(0, diag(bx², by²)), bx, by on a ladder of blurs
// b_k = kMinBlur·√2^k raster cells, each sampled on a grid of spacing kSpacing·b (so every table
// has about (W/b)·(H/b) points), over the raster's domain widened by kPad·b on each side
// (beyond, the blurred clamped TF2 is constant to Φ(−kPad)); built on first use per blur pair.
//
// Gaussian N(m, Σ) (raster cells): Σ = D + Σr with D = diag(bx², by²) from the ladder, bx ≤
// σx·√((1 − |ρ|)/2) and likewise by, so that Σr ≥ D (Σ/2 − D is PSD). (The numbers here are the
// box spline's sums; `gaussian` itself takes a share 0.8 and radius 4.0, and a y ladder of 2^¼
// steps — expected_tf2_fast.cpp, kGaussianShare; max 1.4e−4 off gaussian-exact.) Then E[TF2] =
// E[T_D(m + Z_r)], Z_r ~ N(0, Σr): the Gaussian-weighted sum of the table T_D over its grid points
// within the ellipse of radius kRadius of Σr, weights normalised. That sum is the trapezoid rule
// of a product whose spectrum falls as exp(−½ωᵀ(D⁻¹ + Σr⁻¹)⁻¹ω) ≤ exp(−¼ωᵀDω): at the grid's
// aliasing frequency 2π/h, h = kSpacing·b, exp(−π²/kSpacing²) (2e−7 at kSpacing = 0.8). Where the
// ladder has no blur that small (σ·√((1 − |ρ|)/2) < kMinBlur cells in x or y) or the table would
// be over kMaxTablePoints, the exact expectedTf2Gaussian.
//
// Box spline c + Σ t_i d_i (the fast 2D `uniform`): by columns (boxSpline; docs/models.md): the
// TF2 is Σ_P ψ_P(x)·Z_P(g) over the x basis, each term's law of G from the corners' moments
// E[ψ_P(X)·G^j] (a Fourier series in x) as a Gram–Charlier normal to κ6 (κ4 below the ladder)
// with the widest G-only box exact, and E[Z_P] the trapezoid sum over the y pass of a blur ≤ √½
// of its std (or the rows in closed form below the ladder). Samples with fewer than 8 corners of
// trilinear weight (Uniform2DKernel) or fewer than 2 with a ≠ 0 take expectedTf2UniformRefined
// (the kUniform2DFast settings, refined where they miss). Errors and cost: docs/models.md.
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

#include "udvr/classify/expected_tf2.h"
#include "udvr/classify/expected_tf2_uniform_exact.h"
#include "udvr/util/lanes.h"

namespace udvr {

/// The prefiltered tables of one TF2 raster (header comment); thread-safe, built lazily.
class Tf2BlurTables {
  public:
    static constexpr double kMinBlur = 0.25;  // raster cells
    static constexpr double kSpacing = 0.8;   // grid spacing / blur
    static constexpr double kPad = 6.0;       // blurs beyond the domain on each side
    static constexpr double kRadius = 4.75;   // the residual's window: mass outside 1.2e−5
    static constexpr std::size_t kMaxTablePoints = std::size_t{1} << 21;
    /// Largest TF2 (points) that gets tables: its biquadratic coefficients take 4·(2W − 1)·(2H − 1)
    /// doubles (33 MiB at 512², 134 MiB at 1024²) and are counted under the process's table cap
    /// (expected_tf2_fast.cpp) with the axes' ladders. A larger TF2, or one whose coefficients
    /// do not fit under the cap, gets none: every sample takes the exact evaluation.
    static constexpr std::size_t kMaxRasterPoints = std::size_t{1} << 20;
    /// Whether the tables exist (else every evaluation is the exact one).
    bool available() const { return baseBytes_ > 0; }

    /// Of the TF2 `r` (copied: the tables outlive it).
    explicit Tf2BlurTables(const Tf2Raster<double>& r);
    /// Whether the tables are those of `r`: its size, domain and points (a hash of them).
    bool matches(const Tf2Raster<double>& r) const;
    /// The content hash matches() compares.
    static std::uint64_t hashOf(const Tf2Raster<double>& r);
    ~Tf2BlurTables();
    Tf2BlurTables(const Tf2BlurTables&) = delete;
    Tf2BlurTables& operator=(const Tf2BlurTables&) = delete;

    /// E[(α·c, α)(X, Y)], (X, Y) ~ N((mx, my), [[vxx, vxy], [vxy, vyy]]) in data units.
    /// `r`: the raster the tables are of (matches(r)), for the exact evaluation where no table
    /// applies.
    void gaussian(const Tf2Raster<double>& r, double mx, double my, double vxx, double vxy,
                  double vyy, double out[4]) const;
    /// gaussian over lanes (the render's batches), moments m = (mx, my, vxx, vxy, vyy) per lane:
    /// each live lane's table sum with a row's points in float lanes (the weights by
    /// expNonPositive about the row's vertex, float sums; within 2e−6 of the double sum,
    /// Tf2BlurTables.LaneGaussianMatchesDouble); lanes where no table applies take
    /// expectedTf2Gaussian in double. Dead lanes of `out` are left as they are.
    void gaussian(const Tf2Raster<double>& r, const lanes::Vf m[5], lanes::Mask live,
                  lanes::Vf out[4]) const;
    /// E over the box spline (cx, cy) + Σ t_i·d_i by columns (issue 33, docs/models.md "an
    /// evaluation by columns"): the TF2 is quadratic in x between raster points, Σ_P ψ_P(x)·Z_P(g)
    /// over the x basis ψ_P (expected_tf2_fast.cpp, Axis), so E = Σ_P E[ψ_P(X)·Z_P(G)] exactly;
    /// each term is taken as m_P·E[Z_P(μ_P + Y_P)] with m_P = E[ψ_P(X)] and Y_P the law of G
    /// weighted by ψ_P(X): its mean, variance and κ3 … κ6 from the corners' moments
    /// E[ψ_P(X)·G^j] (j ≤ 6, exact by a Fourier series in x), the widest G-only box exact and the
    /// other G-only boxes in the variance, κ4 and κ6 (a Gram–Charlier density, its first six
    /// moments exact). E[Z_P(μ + Y)] is the trapezoid sum over the y pass of the TF2 blurred by
    /// N(0, b²), b² ≤ ½·var Y, or, below the ladder, the raster's rows in closed form (to κ4,
    /// Edgeworth). A corner holding over 0.15 of var G (and a second over 0.15 of the rest) is
    /// cut along its t into pieces, each a corner of the moments, and E is the mean over the
    /// pieces' centres (a box-dominated law of G is far from any normal series). Returns
    /// false where it took the exact evaluation (expectedTf2UniformRefined) instead: no tables,
    /// fewer than 2 corners (directions with a ≠ 0) or more than 32 directions, non-finite data, a
    /// sample's work past its bounds (expected_tf2_fast.cpp, kColumnsMax…).
    bool boxSpline(const Tf2Raster<double>& r, double cx, double cy, const BoxDirection2* d, int n,
                   double tinyWidth, double out[4]) const;

  private:
    struct Axis;
    struct Table;
    struct Pass;
    struct Window;
    /// The table and window of the table sum for N(·, Σ) in raster cells; false where no table
    /// applies.
    bool windowOf(double t0, double sxx, double sxy, double syy, Window& w) const;
    /// windowOf for `gaussian` (its share, radius and y ladder) at 8 samples in double lanes
    /// (the same values as windowOf; raster cells): the bits of the lanes where a table applies.
    std::uint32_t gaussianWindows(const lanes::V8d& s0, const lanes::V8d& t0, const lanes::V8d& sxx,
                                  const lanes::V8d& sxy, const lanes::V8d& syy, Window win[8],
                                  std::uint32_t& empty) const;
    /// gaussianCells's points over float lanes (gaussian over lanes) in the window `win`
    /// (gaussianWindows) about (s0, t0).
    bool gaussianCellsLanes(const Window& win, double s0, double t0, float out[4]) const;
    /// The y pass of level j (the table rows' sums over the y basis), built on first use under
    /// the process's cap; null where it does not fit.
    const Pass* pass(int j) const;
    /// The table of levels (i, j), built on first use; null where it would be too large.
    const Table* table(int i, int j) const;
    /// The table sum for N(m, Σ) in raster cells (the double body of `gaussian`); false where no
    /// table applies.
    bool gaussianCells(double s0, double t0, double sxx, double sxy, double syy,
                       double out[4]) const;

    std::size_t baseBytes_ = 0;  // q_, qRange_ and the axes, reserved under the cap (0: none)
    int width_ = 2, height_ = 2;
    double x0_ = 0, y0_ = 0, invDx_ = 1, invDy_ = 1;
    std::uint64_t hash_ = 0;
    std::vector<double> q_[4];  // the biquadratic coefficients per channel: (2W − 1) × (2H − 1)
    std::vector<int> qRange_;   // per row R of q_: the columns [lo, hi) not all 0
    /// Per point (j·W + i): the cells with α > 0 at a corner in columns [0, i) and rows [0, j)
    /// (a summed-area table; emptyRectangle).
    std::vector<std::int32_t> alphaCells_;
    mutable std::unique_ptr<std::once_flag[]> passOnce_;
    mutable std::unique_ptr<std::unique_ptr<Pass>[]> passes_;
    std::unique_ptr<Axis> ax_, ay_;
    int levelsX_ = 0, levelsY_ = 0;
    mutable std::unique_ptr<std::once_flag[]> once_;
    mutable std::unique_ptr<std::unique_ptr<Table>[]> tables_;
};

}  // namespace udvr
