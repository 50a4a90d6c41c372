#pragma once
// Designing 2D transfer functions (SPEC §9): the joint histogram of (value, gradient magnitude)
// of a volume's grid points as a grey image with the TF2's colour overlaid by its opacity, as in
// Kniss et al. 2001 and the bottom row of Athawale et al. 2021's Fig. 10.
#include <array>
#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include "udvr/classify/transfer_function_2d.h"
#include "udvr/io/image.h"

namespace udvr {

/// Counts of (x, y) pairs in binsX × binsY equal bins over [x0, x1] × [y0, y1] (bin i covers
/// [x0 + i·Δx, x0 + (i + 1)·Δx), the last one closed).
struct JointHistogram {
    int binsX = 0, binsY = 0;
    std::array<double, 4> domain{0.0, 1.0, 0.0, 1.0};  // x0, x1, y0, y1
    std::vector<double> counts;                        // counts[j·binsX + i], j the y bin
    std::size_t total = 0;                             // pairs seen
    std::size_t outside = 0;  // pairs outside the domain (or NaN): not in any bin
    double xMin = 0.0, xMax = 0.0, yMin = 0.0, yMax = 0.0;  // range of the finite pairs

    double count(int i, int j) const { return counts[static_cast<std::size_t>(j) * binsX + i]; }
};

/// Histogram of the pairs (x[k], y[k]); x and y of equal length, bins ≥ 1, domain non-empty.
JointHistogram jointHistogram(std::span<const float> x, std::span<const float> y, int binsX,
                              int binsY, const std::array<double, 4>& domain);

struct Tf2PlotOptions {
    int width = 720, height = 600;  // pixels of the whole figure
    bool logScale = false;          // grey ∝ log(1 + count) instead of count
    std::string title;              // drawn above the plot when not empty
    std::string xLabel = "value", yLabel = "gradient magnitude";
};

/// The TF2's domain as a plot (x right, y up) with ticks and axis labels: the histogram (when
/// given; it must cover the TF2's domain) as grey, white = empty, black = the fullest bin; over
/// it the TF2's colour with weight 0.85·α/α_max (α_max printed below). Opaque.
ImageRgba renderTf2Plot(const TransferFunction2D& tf, const JointHistogram* histogram,
                        const Tf2PlotOptions& options = {});

}  // namespace udvr
