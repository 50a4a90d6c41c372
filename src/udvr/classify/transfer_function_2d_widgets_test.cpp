#include "udvr/classify/transfer_function_2d_widgets.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "udvr/util/check.h"

namespace udvr {
namespace {

Tf2Widget widget(const decltype(Tf2Widget::shape)& shape, std::array<double, 4> rgba) {
    Tf2Widget w;
    w.shape = shape;
    w.rgba = rgba;
    return w;
}

TEST(Tf2Widgets, BoxIsInclusiveAndSharp) {
    Tf2Box b;
    b.x = {2.0, 5.0};
    b.y = {3.0, 6.0};
    const Tf2Widget w = widget(b, {1, 0, 0, 0.7});
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 3.5, 4.5), 0.7);
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 2.0, 3.0), 0.7);  // corners belong to the box
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 5.0, 6.0), 0.7);
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 5.0, 4.0), 0.7);  // right edge
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 5.0 + 1e-9, 4.0), 0.0);
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 2.0 - 1e-9, 4.0), 0.0);
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 3.0, 6.0 + 1e-9), 0.0);
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 3.0, 2.9), 0.0);

    // On an 11×11 raster over [0, 10]² the points sit on the integers.
    const TransferFunction2D tf = rasterizeWidgets({w}, 11, 11, {0, 10, 0, 10});
    EXPECT_FLOAT_EQ(tf.point(2, 3)[3], 0.7f);
    EXPECT_FLOAT_EQ(tf.point(5, 6)[3], 0.7f);
    EXPECT_FLOAT_EQ(tf.point(1, 3)[3], 0.f);
    EXPECT_FLOAT_EQ(tf.point(6, 4)[3], 0.f);
    EXPECT_FLOAT_EQ(tf.point(3, 4)[0], 1.f);  // colour where α > 0
    EXPECT_FLOAT_EQ(tf.point(8, 8)[0], 0.f);  // colour 0 where every α_w = 0
}

TEST(Tf2Widgets, TriangleTentAndFlat) {
    Tf2Triangle t;
    t.apex = {5.0, 0.0};
    t.top = 10.0;
    t.width = 4.0;  // half width 2 at the top, 1 at y = 5
    const double a = 0.8;
    Tf2Widget w = widget(t, {0, 1, 0, a});
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 5.0, 10.0), a);  // centre line
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 5.0, 2.5), a);
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 6.0, 10.0), 0.5 * a);
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 4.0, 10.0), 0.5 * a);
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 5.5, 5.0), 0.5 * a);
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 4.25, 5.0), 0.25 * a);
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 7.0, 10.0), 0.0);   // on the slanted edge
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 6.01, 5.0), 0.0);   // outside
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 5.0, 10.01), 0.0);  // above the top edge
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 5.0, -0.01), 0.0);  // below the apex
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 5.0, 0.0), a);      // the apex itself
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 5.01, 0.0), 0.0);

    std::get<Tf2Triangle>(w.shape).flat = true;
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 6.99, 10.0), a);
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 5.99, 5.0), a);
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 6.01, 5.0), 0.0);

    // Upside down: apex at the top.
    Tf2Triangle down;
    down.apex = {0.0, 10.0};
    down.top = 0.0;
    down.width = 2.0;
    const Tf2Widget wd = widget(down, {0, 1, 0, 1.0});
    EXPECT_DOUBLE_EQ(widgetOpacity(wd, 0.5, 0.0), 0.5);
    EXPECT_DOUBLE_EQ(widgetOpacity(wd, 0.25, 5.0), 0.5);
    EXPECT_DOUBLE_EQ(widgetOpacity(wd, 0.0, 11.0), 0.0);
}

TEST(Tf2Widgets, EllipseAtOneSigmaAlongRotatedAxes) {
    Tf2Ellipse e;
    e.center = {2.0, 3.0};
    e.sigma = {1.0, 0.5};
    e.angleDeg = 30.0;
    const double a = 0.6;
    const Tf2Widget w = widget(e, {0, 0, 1, a});
    const double c = std::cos(std::numbers::pi / 6), s = std::sin(std::numbers::pi / 6);
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 2.0, 3.0), a);
    // 1σ along the rotated sx axis (cos 30°, sin 30°) and along the sy axis (−sin, cos).
    EXPECT_NEAR(widgetOpacity(w, 2.0 + c, 3.0 + s), a * std::exp(-0.5), 1e-14);
    EXPECT_NEAR(widgetOpacity(w, 2.0 - c, 3.0 - s), a * std::exp(-0.5), 1e-14);
    EXPECT_NEAR(widgetOpacity(w, 2.0 - 0.5 * s, 3.0 + 0.5 * c), a * std::exp(-0.5), 1e-14);
    // 2σ along sx: e^−2; 1σ along both: e^−1.
    EXPECT_NEAR(widgetOpacity(w, 2.0 + 2 * c, 3.0 + 2 * s), a * std::exp(-2.0), 1e-14);
    EXPECT_NEAR(widgetOpacity(w, 2.0 + c - 0.5 * s, 3.0 + s + 0.5 * c), a * std::exp(-1.0), 1e-14);
    // The unrotated axis is not a principal one: 1 along +x is not 1σ.
    EXPECT_GT(std::abs(widgetOpacity(w, 3.0, 3.0) - a * std::exp(-0.5)), 1e-3);
    // Cut off at 3σ (default).
    EXPECT_NEAR(widgetOpacity(w, 2.0 + 2.99 * c, 3.0 + 2.99 * s), a * std::exp(-0.5 * 2.99 * 2.99),
                1e-14);
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 2.0 + 3.01 * c, 3.0 + 3.01 * s), 0.0);
}

TEST(Tf2Widgets, BandDistancesAreScaledByTheHalfWidths) {
    Tf2Band b;
    b.points = {{0.0, 0.0}, {10.0, 0.0}, {10.0, 10.0}};
    b.halfWidth = {1.0, 2.0};
    const double a = 0.5;
    Tf2Widget w = widget(b, {1, 1, 0, a});
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 5.0, 1.9), a);    // d = 0.95 from the first segment
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 5.0, 2.1), 0.0);  // d = 1.05
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 11.0, 5.0), a);   // d = 1 from the second: inclusive
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 12.0, -1.0), 0.0);

    auto& band = std::get<Tf2Band>(w.shape);
    band.tent = true;
    EXPECT_NEAR(widgetOpacity(w, 5.0, 1.9), a * 0.05, 1e-12);
    EXPECT_NEAR(widgetOpacity(w, 5.0, -1.0), a * 0.5, 1e-12);
    EXPECT_NEAR(widgetOpacity(w, 10.5, 3.0), a * 0.5, 1e-12);  // dx/hx = 0.5 from segment 2
    // Beyond the polyline's end the nearest point is the end point (10, 10).
    EXPECT_NEAR(widgetOpacity(w, 10.5, 10.5), a * (1.0 - std::sqrt(0.25 + 0.0625)), 1e-12);
    EXPECT_DOUBLE_EQ(widgetOpacity(w, 11.0, 5.0), 0.0);

    // One point: a (scaled) disc.
    Tf2Band dot;
    dot.points = {{3.0, 3.0}};
    dot.halfWidth = {1.0, 1.0};
    const Tf2Widget wd = widget(dot, {1, 1, 1, 1.0});
    EXPECT_DOUBLE_EQ(widgetOpacity(wd, 4.0, 3.0), 1.0);  // d = 1
    EXPECT_DOUBLE_EQ(widgetOpacity(wd, 3.5, 3.5), 1.0);  // d = 0.71
    EXPECT_DOUBLE_EQ(widgetOpacity(wd, 3.8, 3.8), 0.0);  // d = 1.13
    // A repeated point (zero-length segment) is a point too.
    dot.points = {{3.0, 3.0}, {3.0, 3.0}};
    EXPECT_DOUBLE_EQ(widgetOpacity(widget(dot, {1, 1, 1, 1.0}), 3.0, 4.0), 1.0);
    EXPECT_DOUBLE_EQ(widgetOpacity(widget(dot, {1, 1, 1, 1.0}), 3.8, 3.8), 0.0);
}

TEST(Tf2Widgets, OverlapsCombineOpacityAndWeightColour) {
    Tf2Box left, right;
    left.x = {0.0, 6.0};
    left.y = {0.0, 10.0};
    right.x = {4.0, 10.0};
    right.y = {0.0, 10.0};
    const std::vector<Tf2Widget> ws = {widget(left, {1, 0, 0, 0.5}),
                                       widget(right, {0, 0, 1, 0.25})};
    const TransferFunction2D tf = rasterizeWidgets(ws, 11, 3, {0, 10, 0, 10});
    const float* only1 = tf.point(2, 1);
    EXPECT_FLOAT_EQ(only1[3], 0.5f);
    EXPECT_FLOAT_EQ(only1[0], 1.f);
    EXPECT_FLOAT_EQ(only1[2], 0.f);
    const float* both = tf.point(5, 1);
    EXPECT_FLOAT_EQ(both[3], static_cast<float>(1.0 - 0.5 * 0.75));  // 1 − Π(1 − α_w)
    EXPECT_FLOAT_EQ(both[0], static_cast<float>(0.5 / 0.75));        // Σ α_w c_w / Σ α_w
    EXPECT_FLOAT_EQ(both[1], 0.f);
    EXPECT_FLOAT_EQ(both[2], static_cast<float>(0.25 / 0.75));
    const float* only2 = tf.point(8, 2);
    EXPECT_FLOAT_EQ(only2[3], 0.25f);
    EXPECT_FLOAT_EQ(only2[2], 1.f);
}

TEST(Tf2Widgets, RasterPointsSitOnTheDomainGrid) {
    Tf2Ellipse e;
    e.center = {0.3, 40.0};
    e.sigma = {0.5, 20.0};
    e.angleDeg = -20.0;
    const Tf2Widget w = widget(e, {0.2, 0.4, 0.6, 0.9});
    const std::array<double, 4> domain{-1.0, 2.0, 10.0, 70.0};
    const TransferFunction2D tf = rasterizeWidgets({w}, 7, 5, domain);
    EXPECT_EQ(tf.width, 7);
    EXPECT_EQ(tf.height, 5);
    EXPECT_EQ(tf.x0, -1.0);
    EXPECT_EQ(tf.y1, 70.0);
    for (int j = 0; j < 5; ++j)
        for (int i = 0; i < 7; ++i) {
            const double x = -1.0 + i * 3.0 / 6, y = 10.0 + j * 60.0 / 4;
            EXPECT_FLOAT_EQ(tf.point(i, j)[3], static_cast<float>(widgetOpacity(w, x, y)))
                << i << "," << j;
        }
    EXPECT_THROW(rasterizeWidgets({w}, 1, 5, domain), UdvrError);
    EXPECT_THROW(rasterizeWidgets({w}, 4, 4, {1.0, 1.0, 0.0, 1.0}), UdvrError);
    // No widgets: α = 0 everywhere.
    const TransferFunction2D empty = rasterizeWidgets({}, 3, 3, domain);
    for (float v : empty.rgba) EXPECT_EQ(v, 0.f);
}

// TransferFunction2D's lookup (classify/transfer_function_2d.h), against hand computation.
TEST(TransferFunction2DLookup, BilinearInsideClampedOutside) {
    TransferFunction2D tf;
    tf.width = 3;
    tf.height = 2;
    tf.x0 = 0.0;
    tf.x1 = 4.0;  // columns at x = 0, 2, 4
    tf.y0 = 10.0;
    tf.y1 = 20.0;  // rows at y = 10, 20
    // Channel ch of point (i, j) = (i + 3j + 1)/10 + ch/100; α = (i + 3j)/8.
    tf.rgba.resize(24);
    for (int j = 0; j < 2; ++j)
        for (int i = 0; i < 3; ++i)
            for (int ch = 0; ch < 4; ++ch)
                tf.rgba[(j * 3 + i) * 4 + ch] =
                    ch < 3 ? static_cast<float>((i + 3 * j + 1) / 10.0 + ch / 100.0)
                           : static_cast<float>((i + 3 * j) / 8.0);
    tf.validate();
    const auto at = [&](int i, int j, int ch) { return double(tf.point(i, j)[ch]); };
    // (x, y) = (3, 12.5): cell (1, 0), fx = 0.5, fy = 0.25.
    const auto v = tf.colorOpacityAt(3.0, 12.5);
    for (int ch = 0; ch < 4; ++ch) {
        const double lo = at(1, 0, ch) + 0.5 * (at(2, 0, ch) - at(1, 0, ch));
        const double hi = at(1, 1, ch) + 0.5 * (at(2, 1, ch) - at(1, 1, ch));
        EXPECT_NEAR(v[ch], lo + 0.25 * (hi - lo), 1e-7) << ch;
    }
    // α at (3, 12.5) by hand: α(i, j) = (i + 3j)/8 is linear, so (1.5 + 0.75)/8.
    EXPECT_NEAR(v[3], 2.25 / 8, 1e-7);
    // Points exactly.
    EXPECT_NEAR(tf.colorOpacityAt(2.0, 20.0)[3], at(1, 1, 3), 1e-7);
    EXPECT_NEAR(tf.colorOpacityAt(4.0, 10.0)[0], at(2, 0, 0), 1e-7);
    // Clamped: left of x0 is column 0, above y1 row 1, both corners beyond.
    EXPECT_NEAR(tf.colorOpacityAt(-5.0, 15.0)[3], 0.5 * (at(0, 0, 3) + at(0, 1, 3)), 1e-7);
    EXPECT_NEAR(tf.colorOpacityAt(1.0, 99.0)[1], 0.5 * (at(0, 1, 1) + at(1, 1, 1)), 1e-7);
    EXPECT_NEAR(tf.colorOpacityAt(9.0, -3.0)[2], at(2, 0, 2), 1e-7);
    EXPECT_NEAR(tf.colorOpacityAt(9.0, 25.0)[3], at(2, 1, 3), 1e-7);
    // classify multiplies colour by α.
    const Rgba r = tf.classify(3.0, 12.5);
    EXPECT_NEAR(r.r, v[0] * v[3], 1e-6);
    EXPECT_NEAR(r.a, v[3], 1e-6);
}

// A widget whose arithmetic gives NaN (an angle whose radians overflow; the JSON reader reduces
// angles modulo 360, a C++ caller may not) is named, not reported as a colour out of [0, 1].
TEST(Tf2Widgets, NanOpacityNamesTheWidget) {
    Tf2Widget box{Tf2Box{}, {1, 0, 0, 1}};
    Tf2Ellipse e;
    e.center = {0.5, 0.5};
    e.angleDeg = 1e308;
    Tf2Widget ellipse{e, {0, 1, 0, 1}};
    try {
        rasterizeWidgets({box, ellipse}, 8, 8, {0, 1, 0, 1});
        FAIL() << "no error";
    } catch (const UdvrError& err) {
        EXPECT_EQ(std::string(err.what()).rfind("widget 1 has no opacity (NaN) at x = 0, y = 0", 0),
                  0u)
            << err.what();
    }
}

}  // namespace
}  // namespace udvr
