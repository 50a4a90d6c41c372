#pragma once
// 1D transfer functions (SPEC §4): colour and opacity piecewise linear between control
// points, clamped outside; two points at the same x make a step (the later one holds from x on).
#include <array>
#include <utility>
#include <vector>

#include "udvr/util/check.h"

namespace udvr {

/// Classification result: opacity-weighted colour and opacity, (E[α·r], E[α·g], E[α·b], E[α]).
struct Rgba {
    float r = 0.f, g = 0.f, b = 0.f, a = 0.f;
};

struct TransferFunction1D {
    std::vector<double> colorX;                // ascending (non-decreasing) data values
    std::vector<std::array<double, 3>> color;  // r,g,b in [0,1] at colorX
    std::vector<double> opacityX;              // ascending (non-decreasing) data values
    std::vector<double> opacity;               // α in [0,1] at opacityX

    /// Colour at x (piecewise linear, clamped, steps: right-continuous).
    std::array<double, 3> colorAt(double x) const;
    /// Opacity at x (piecewise linear, clamped, steps: right-continuous).
    double opacityAt(double x) const;
    /// (α·r, α·g, α·b, α) at x.
    Rgba classify(double x) const;
    /// Smallest and largest control point x over both functions.
    std::pair<double, double> domain() const;
    /// Closed value intervals outside which α = 0 (merged, ascending); unbounded ends use ±inf.
    std::vector<std::pair<double, double>> nonZeroOpacityRanges() const;
    /// Throws UdvrError unless both functions have ≥1 point, x ascending, values in [0,1], finite.
    void validate() const;
};

}  // namespace udvr
