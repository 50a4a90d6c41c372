#pragma once
// 2D transfer functions (SPEC §9): TF2(x, y) = (c, α) on a raster of W×H points over the domain
// [x0, x1] × [y0, y1] — x the value (or field 1), y the gradient magnitude G (or field 2);
// column i at x0 + i·(x1 − x0)/(W − 1), row j at y0 + j·(y1 − y0)/(H − 1) (row 0 the smallest
// y). Colour and α are each bilinear between the points and clamped outside the domain, so
// α·c is a product of two bilinear functions (biquadratic in a cell). α is per unit distance,
// as the 1D TF's opacity.
#include <array>
#include <utility>
#include <vector>

#include "udvr/classify/transfer_function.h"

namespace udvr {

/// Largest raster per axis (any form; widgets are rasterised within it too).
inline constexpr int kMaxTf2Resolution = 8192;

struct TransferFunction2D {
    int width = 0, height = 0;  // points along x and y (each ≥ 2)
    double x0 = 0.0, x1 = 1.0;  // domain along x (x0 < x1, finite)
    double y0 = 0.0, y1 = 1.0;  // domain along y (y0 < y1, finite)
    std::vector<float> rgba;    // (r, g, b, α) per point: rgba[(j·W + i)·4 + ch]

    /// (r, g, b, α) of point (i, j).
    const float* point(int i, int j) const {
        return rgba.data() + (static_cast<std::size_t>(j) * width + i) * 4;
    }
    /// Colour and α at (x, y), each bilinear, clamped outside the domain: (c_r, c_g, c_b, α).
    std::array<double, 4> colorOpacityAt(double x, double y) const;
    /// (α·r, α·g, α·b, α) at (x, y).
    Rgba classify(double x, double y) const;
    /// Closed x intervals outside which α = 0 for every y (merged, ascending; unbounded ends
    /// ±inf where α > 0 on the domain's first or last column): the 1D skipping ranges.
    std::vector<std::pair<double, double>> nonZeroOpacityXRanges() const;
    /// Per cell (j·(W − 1) + i, the cell between points i, i + 1 and j, j + 1): 0 where a corner
    /// has α > 0, else the Chebyshev distance in cells to the nearest such cell (W + H when
    /// there is none), so every cell closer than it has α = 0 on its whole area.
    std::vector<float> emptyCellDistances() const;
    /// Whether a corner of cell (i, j) (points i, i + 1 × j, j + 1) has α > 0.
    bool cellOpaque(int i, int j) const;
    /// Per cell (j·(W − 1) + i): the run of cells [lo, hi) (point columns lo < hi, stored as two
    /// floats) that contains it, over which both of its rows (j, j + 1) are linear in x within
    /// `tolerance` in every channel, and whose cells are all opaque or all empty (cellOpaque).
    /// Bilinear interpolation between the run's four corner points then differs from the
    /// raster's by at most `tolerance` on the whole run (0 for empty runs). Greedy from the
    /// left; O(W·H).
    std::vector<float> linearCellRuns(double tolerance) const;
    /// Per row j: the last row j' ≥ j such that rows j … j' are identical (every point's four
    /// channels equal), as a float. Between rows j and j' the TF2 does not depend on y.
    std::vector<float> identicalRowsUpTo() const;
    /// Per point (j·W + i, 8 floats): the integral over raster x coordinates [0, i] of row j's
    /// (α·r, α·g, α·b, α) (each of α and c linear between points, so α·c quadratic), summed in
    /// double and stored as float hi (4) then lo (4), hi + lo within 2^−48 of the sum: a
    /// difference of two of them keeps float's relative precision (as the 1D TF's cumulative
    /// integrals, TfPieces).
    std::vector<float> rowPrefixIntegrals() const;
    /// The banded segment walk's prefix tables (Tf2Raster::bandPrefix; layout and use in
    /// detail::bandRunSum, tf2_banded_walk.h): per band of cells between two lines of one axis
    /// and per line of the other, kTf2BandMoments doubles, the prefix sums along the band of its
    /// cells' moments of α and α·c with the cross fraction linear along the band. Bands between
    /// x lines first ((W − 1)·H records), then bands between y lines ((H − 1)·W records):
    /// (2·W·H − W − H)·kTf2BandMoments·8 bytes (22 MB for 256²).
    std::vector<double> bandPrefixMoments() const;
    /// Throws UdvrError unless 2 ≤ W, H ≤ kMaxTf2Resolution, rgba has W·H·4 values in [0, 1],
    /// the domain is finite with x0 < x1, y0 < y1, and its widths and raster steps are finite
    /// and non-zero in float (the kernels' coordinates).
    void validate() const;
};

/// A TF2 that ignores y: the 1D TF sampled at `width` points over [x0, x1] (its breakpoints
/// must lie on that grid for the two to agree exactly), H = 2 rows over [y0, y1].
TransferFunction2D transferFunction2DFrom1D(const TransferFunction1D& tf, int width, double x0,
                                            double x1, double y0 = 0.0, double y1 = 1.0);

}  // namespace udvr
