#pragma once
// Figures of the experiments (Athawale et al. 2021, Figs. 4–9): panels of labelled images with
// captions (RMSE, timings) and line plots (Fig. 5a), drawn with cairo and written as PNG.
#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "udvr/classify/transfer_function.h"
#include "udvr/io/image.h"

namespace udvr {

/// One cell of a panel: an image (an empty image leaves the cell blank) and caption lines drawn
/// under it, the first in bold (the label).
struct FigureCell {
    ImageRgba image;
    std::vector<std::string> caption;
};

/// A grid of cells, row-major, `columns` per row, under an optional title.
struct FigurePanel {
    std::string title;
    int columns = 4;
    std::vector<FigureCell> cells;
};

/// Where things go in a panel, in panel pixels (top-left origin).
struct PanelLayout {
    int width = 0, height = 0;
    int cellWidth = 0, cellHeight = 0;            // image area of each cell: the largest image
    int captionHeight = 0;                        // text band under each image
    std::vector<int> rowHeight;                   // image area of each row: its largest image
    std::vector<std::array<int, 2>> imageOrigin;  // top-left pixel of each cell's image
};

/// The layout renderPanel uses (images are centred horizontally in their cell, top-aligned;
/// each row as tall as its tallest image, so one large plot does not space out every row).
PanelLayout panelLayout(const FigurePanel& panel);
/// Draw a panel on white. Images are pasted as their RGB (they are already composited over the
/// background), byte-exact to the 8-bit rounding of writeFigurePng; the result is opaque.
ImageRgba renderPanel(const FigurePanel& panel);

/// One line of a plot; x and y of equal length. Non-finite y values are left out.
struct PlotSeries {
    std::string label;
    std::vector<double> x, y;
    std::array<double, 3> color{0.0, 0.0, 0.0};
    bool dashed = false;
};

/// One set of axes.
struct PlotAxes {
    std::string title, xLabel, yLabel;
    std::vector<PlotSeries> series;
    bool logX = false;  // x ticks at the series' x values either way
};

/// Side-by-side line plots sharing one y range (so they compare at a glance), each with ticks
/// and axis labels, and one legend of the first plot's series (the plots are meant to share
/// them) in a column on the right; width×height pixels in all, white background, opaque.
ImageRgba renderLinePlots(const std::vector<PlotAxes>& plots, int width, int height);

/// Write as 8-bit RGB(A) PNG through cairo, values clamped to [0,1] and rounded, alpha dropped
/// (figures are opaque); atomically.
void writeFigurePng(const std::filesystem::path& path, const ImageRgba& image);

/// Box-filter an image down by an integer factor (thumbnails for panels); the last partial
/// block of a row or column averages what it has.
ImageRgba downsampleImage(const ImageRgba& image, int factor);

/// Draw a 1D transfer function (Fig. 4g style): the colour bar along the bottom and the opacity
/// curve above it over the TF's domain, with the domain's ends labelled; width×height, opaque.
ImageRgba renderTransferFunction(const TransferFunction1D& tf, int width, int height);

/// "Nice" axis ticks (1, 2, 5 × 10^k) covering [lo, hi], at most about `maxTicks`.
std::vector<double> niceTicks(double lo, double hi, int maxTicks);

/// `image` with a vertical colour scale to its right: the difference map (differenceColor)
/// from 0 at the bottom to `maxValue` at the top, with tick labels and `label` above it — what
/// `udvr compare --diff` writes, so a reader knows what yellow means. The image is unchanged
/// in the left `image.width` columns; the scale adds kColourScaleWidth columns (white).
ImageRgba withDifferenceScale(const ImageRgba& image, double maxValue, const std::string& label);
inline constexpr int kColourScaleWidth = 72;

}  // namespace udvr
