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
// σx·√((1 − |ρ|)/2) and likewise by, so that Σr ≥ D (Σ/2 − D is PSD). Then E[TF2] =
// E[T_D(m + Z_r)], Z_r ~ N(0, Σr): the Gaussian-weighted sum of the table T_D over its grid points
// within the ellipse of radius kRadius of Σr, weights normalised. That sum is the trapezoid rule
// of a product whose spectrum falls as exp(−½ωᵀ(D⁻¹ + Σr⁻¹)⁻¹ω) ≤ exp(−¼ωᵀDω): at the grid's
// aliasing frequency 2π/h, h = kSpacing·b, exp(−π²/kSpacing²) (2e−7 at kSpacing = 0.8). Where the
// ladder has no blur that small (σ·√((1 − |ρ|)/2) < kMinBlur cells in x or y) or the table would
// be over kMaxTablePoints, the exact expectedTf2Gaussian.
//
// Box spline c + Σ t_i d_i: the widest kExactBoxes directions (by extent in raster cells) are
// kept as boxes, the rest replaced by the normal of the same covariance; E = mean over an
// m-point Gauss–Legendre rule per kept box (on [−1, 1], pieces ≤ the Gaussian rest's scale) of
// the Gaussian expectation above. Errors: docs/models.md.
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

#include "udvr/classify/expected_tf2.h"
#include "udvr/classify/expected_tf2_uniform_exact.h"

namespace udvr {

/// The prefiltered tables of one TF2 raster (header comment); thread-safe, built lazily.
class Tf2BlurTables {
  public:
    static constexpr double kMinBlur = 0.25;  // raster cells
    static constexpr double kSpacing = 0.8;   // grid spacing / blur
    static constexpr double kPad = 6.0;       // blurs beyond the domain on each side
    static constexpr double kRadius = 4.75;   // the residual's window: mass outside 1.2e−5
    static constexpr std::size_t kMaxTablePoints = std::size_t{1} << 21;

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
    /// E over the box spline (cx, cy) + Σ t_i·d_i; `tinyWidth` goes to the exact evaluation
    /// where it is taken.
    /// False (out untouched) where the kept boxes would take over kMaxBoxPieces Gauss–Legendre
    /// pieces (their product): the caller takes another rule there.
    static constexpr int kMaxBoxPieces = 4;
    bool boxSpline(const Tf2Raster<double>& r, double cx, double cy, const BoxDirection2* d, int n,
                   double tinyWidth, double out[4]) const;

  private:
    struct Axis;
    struct Table;
    struct Pass;
    /// The y pass of level j (the table rows' sums over the y basis), built on first use.
    const Pass& pass(int j) const;
    /// The table of levels (i, j), built on first use; null where it would be too large.
    const Table* table(int i, int j) const;
    /// The table sum for N(m, Σ) in raster cells; false where no table applies. With `boxes`
    /// (n of them, raster cells), the density is the Edgeworth series of a sum of those boxes
    /// of covariance Σ to its κ4 term.
    /// `quartic` holds the series' coefficients between calls with the same Σ and boxes
    /// (computed on the first).
    struct Quartic {
        bool ready = false;
        double c[5][5] = {};
    };
    bool gaussianCells(double s0, double t0, double sxx, double sxy, double syy, double out[4],
                       const double (*boxes)[2] = nullptr, int n = 0,
                       Quartic* quartic = nullptr) const;

    int width_ = 2, height_ = 2;
    double x0_ = 0, y0_ = 0, invDx_ = 1, invDy_ = 1;
    std::uint64_t hash_ = 0;
    std::vector<double> q_[4];  // the biquadratic coefficients per channel: (2W − 1) × (2H − 1)
    std::vector<int> qRange_;   // per row R of q_: the columns [lo, hi) not all 0
    mutable std::unique_ptr<std::once_flag[]> passOnce_;
    mutable std::unique_ptr<std::unique_ptr<Pass>[]> passes_;
    std::unique_ptr<Axis> ax_, ay_;
    int levelsX_ = 0, levelsY_ = 0;
    mutable std::unique_ptr<std::once_flag[]> once_;
    mutable std::unique_ptr<std::unique_ptr<Table>[]> tables_;
};

}  // namespace udvr
