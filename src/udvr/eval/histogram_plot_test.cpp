#include "udvr/eval/histogram_plot.h"

#include <gtest/gtest.h>

#include <vector>

namespace udvr {
namespace {

// Share of pixels in a column range whose colour is close to (r, g, b).
double shareOfColour(const ImageRgba& im, int x0, int x1, float r, float g, float b) {
    int hits = 0, all = 0;
    for (int y = 0; y < im.height; ++y)
        for (int x = x0; x < x1; ++x, ++all) {
            const float* p = im.pixel(x, y);
            hits += std::abs(p[0] - r) < 0.03f && std::abs(p[1] - g) < 0.03f &&
                    std::abs(p[2] - b) < 0.03f;
        }
    return static_cast<double>(hits) / all;
}

TEST(HistogramPlot, BarsStandWhereTheValuesAre) {
    std::vector<float> values(1000, 0.9f);  // everything in the last tenth of [0, 1]
    const Histogram h = histogramOf(values, 0.0, 1.0, 10);
    HistogramPlotOptions o;
    o.width = 400;
    o.height = 300;
    const ImageRgba im = renderHistogramPlot(h, nullptr, o);
    ASSERT_EQ(im.width, 400);
    ASSERT_EQ(im.height, 300);
    // The bar colour fills much of the right end of the plot and none of its left half.
    EXPECT_GT(shareOfColour(im, 340, 370, 0.45f, 0.5f, 0.6f), 0.3);
    EXPECT_EQ(shareOfColour(im, 100, 200, 0.45f, 0.5f, 0.6f), 0.0);
}

TEST(HistogramPlot, ATransferFunctionAddsItsColourStrip) {
    std::vector<float> values{0.1f, 0.5f, 0.5f, 0.9f};
    const Histogram h = histogramOf(values, 0.0, 1.0, 4);
    TransferFunction1D tf;
    tf.colorX = {0.0};
    tf.color = {{0.0, 1.0, 0.0}};  // pure green everywhere
    tf.opacityX = {0.0, 1.0};
    tf.opacity = {0.0, 0.7};
    const ImageRgba without = renderHistogramPlot(h, nullptr);
    const ImageRgba with = renderHistogramPlot(h, &tf);
    EXPECT_EQ(shareOfColour(without, 0, without.width, 0.f, 1.f, 0.f), 0.0);
    EXPECT_GT(shareOfColour(with, 0, with.width, 0.f, 1.f, 0.f), 0.005);
}

}  // namespace
}  // namespace udvr
