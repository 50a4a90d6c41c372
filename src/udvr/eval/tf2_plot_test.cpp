#include "udvr/eval/tf2_plot.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "udvr/classify/transfer_function_2d_widgets.h"

namespace udvr {
namespace {

TEST(Tf2Plot, JointHistogramCountsByHand) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    // 2×2 bins over [0, 1] × [0, 2]: x bins [0, .5) [.5, 1], y bins [0, 1) [1, 2].
    const std::vector<float> x = {0.0f, 0.49f, 0.5f, 1.0f, 1.01f, 0.2f, nan, 0.7f};
    const std::vector<float> y = {0.0f, 1.5f, 0.99f, 2.0f, 1.0f, -0.1f, 1.0f, 1.0f};
    const JointHistogram h = jointHistogram(x, y, 2, 2, {0.0, 1.0, 0.0, 2.0});
    EXPECT_EQ(h.total, 8u);
    EXPECT_EQ(h.outside, 3u);       // x = 1.01, y = −0.1, NaN
    EXPECT_EQ(h.count(0, 0), 1.0);  // (0, 0)
    EXPECT_EQ(h.count(0, 1), 1.0);  // (0.49, 1.5)
    EXPECT_EQ(h.count(1, 0), 1.0);  // (0.5, 0.99)
    EXPECT_EQ(h.count(1, 1), 2.0);  // (1, 2) in the closed last bins, (0.7, 1)
    EXPECT_FLOAT_EQ(static_cast<float>(h.xMax), 1.01f);
    EXPECT_FLOAT_EQ(static_cast<float>(h.yMin), -0.1f);
}

// Pixels whose colour is near (r, g, b).
int countNear(const ImageRgba& im, float r, float g, float b, double* meanX = nullptr,
              double* meanY = nullptr) {
    int n = 0;
    double sx = 0, sy = 0;
    for (int y = 0; y < im.height; ++y)
        for (int x = 0; x < im.width; ++x) {
            const float* p = im.pixel(x, y);
            if (std::abs(p[0] - r) < 0.12f && std::abs(p[1] - g) < 0.12f &&
                std::abs(p[2] - b) < 0.12f) {
                ++n;
                sx += x;
                sy += y;
            }
        }
    if (meanX) *meanX = n ? sx / n : 0;
    if (meanY) *meanY = n ? sy / n : 0;
    return n;
}

TEST(Tf2Plot, OverlayFollowsTheDomainWithLargerYUp) {
    // A red box over the right half of x and the upper half of y.
    Tf2Widget w;
    Tf2Box b;
    b.x = {5.0, 10.0};
    b.y = {50.0, 100.0};
    w.shape = b;
    w.rgba = {1.0, 0.0, 0.0, 1.0};
    const TransferFunction2D tf = rasterizeWidgets({w}, 64, 64, {0, 10, 0, 100});
    Tf2PlotOptions o;
    o.width = 400;
    o.height = 300;
    const ImageRgba plain = renderTf2Plot(tf, nullptr, o);
    EXPECT_EQ(plain.width, 400);
    EXPECT_EQ(plain.height, 300);
    double mx = 0, my = 0;
    const float red = 0.15f + 0.85f;  // weight 0.85 over white: (1, 0.15, 0.15)
    const int reds = countNear(plain, red, 0.15f, 0.15f, &mx, &my);
    EXPECT_GT(reds, 400 * 300 / 10);
    EXPECT_GT(mx, 200.0);  // right half
    EXPECT_LT(my, 150.0);  // upper half of the image = larger y

    // A histogram with every pair in the lower-left bin darkens the lower left.
    const std::vector<float> x(100, 0.5f), y(100, 5.0f);
    const JointHistogram h = jointHistogram(x, y, 4, 4, {0, 10, 0, 100});
    const ImageRgba over = renderTf2Plot(tf, &h, o);
    double gx = 0, gy = 0;
    const int darkPlain = countNear(plain, 0.08f, 0.08f, 0.08f);
    const int dark = countNear(over, 0.08f, 0.08f, 0.08f, &gx, &gy);
    EXPECT_GT(dark - darkPlain, 400 * 300 / 40);
    EXPECT_EQ(countNear(over, red, 0.15f, 0.15f), reds);  // the box's bins are empty
}

}  // namespace
}  // namespace udvr
