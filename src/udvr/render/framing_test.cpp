#include "udvr/render/framing.h"

#include <gtest/gtest.h>

#include <cmath>

#include "udvr/render/camera.h"
#include "udvr/util/check.h"

namespace udvr {
namespace {

using Vec3 = std::array<double, 3>;

// Where a world point lands in the image, in units of the half height (|y| ≤ 1 and
// |x| ≤ aspect inside), by the ray generator's own basis.
std::array<double, 2> project(const CameraFrame& f, const Vec3& p) {
    const Vec3 r{p[0] - f.eye[0], p[1] - f.eye[1], p[2] - f.eye[2]};
    const auto dot = [](const Vec3& a, const Vec3& b) {
        return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    };
    const double depth = dot(r, f.forward);
    return {dot(r, f.right) / (depth * f.halfHeight), dot(r, f.up) / (depth * f.halfHeight)};
}

TEST(Framing, EveryCornerOfTheBoxIsInsideTheImageAndOneTouchesTheMargin) {
    const std::array<double, 6> box{-1.0, 3.0, 0.0, 1.0, 10.0, 10.5};  // flat, off-centre
    for (const auto& [view, az, el, aspect] :
         {std::tuple{"+x", 0.0, 0.0, 1.0}, std::tuple{"-y", 30.0, 20.0, 2.0},
          std::tuple{"+z", -45.0, 60.0, 0.5}, std::tuple{"-z", 10.0, -80.0, 1.0}}) {
        const Camera cam = framedCamera(box, parseViewDirection(view), az, el, 1.0, 30.0, aspect);
        const int h = 100, w = static_cast<int>(std::lround(100 * aspect));
        const CameraFrame f = makeCameraFrame(cam, w, h);
        double largest = 0.0;  // the largest |coordinate| / its limit over the corners
        double lo[2] = {1e9, 1e9}, hi[2] = {-1e9, -1e9};
        for (int c = 0; c < 8; ++c) {
            const Vec3 p{box[c & 1], box[2 + ((c >> 1) & 1)], box[4 + ((c >> 2) & 1)]};
            const auto xy = project(f, p);
            largest = std::max({largest, std::abs(xy[0]) / f.aspect, std::abs(xy[1])});
            for (int a = 0; a < 2; ++a)
                lo[a] = std::min(lo[a], xy[a]), hi[a] = std::max(hi[a], xy[a]);
        }
        EXPECT_LE(largest, 0.95 + 1e-9) << view;
        EXPECT_GE(largest, 0.95 - 1e-6) << view;  // tight, not just inside
        // Centred: the projected box reaches as far left as right, as far up as down (to a
        // hundredth of a pixel at 100 px).
        EXPECT_NEAR(lo[0] + hi[0], 0.0, 2e-4) << view;
        EXPECT_NEAR(lo[1] + hi[1], 0.0, 2e-4) << view;
    }
}

TEST(Framing, TurnsAsTheSpecDefaultCameraDoes) {
    // Looking along −z with up +y, Azimuth/Elevation must give SPEC §5's direction and up (the
    // focal point differs: the framed camera centres the projected box).
    const std::array<double, 6> box{0, 2, 0, 1, 0, 4};
    for (double az : {0.0, 30.0, -120.0})
        for (double el : {0.0, 20.0, 89.0}) {
            const Camera framed = framedCamera(box, ViewDirection{}, az, el, 1.0, 30.0, 1.0);
            const Camera spec = defaultCamera(box, az, el, 1.0, 30.0);
            Vec3 a{}, b{};
            double na = 0, nb = 0;
            for (int i = 0; i < 3; ++i) {
                a[i] = framed.position[i] - framed.focalPoint[i];
                b[i] = spec.position[i] - spec.focalPoint[i];
                na += a[i] * a[i];
                nb += b[i] * b[i];
            }
            for (int i = 0; i < 3; ++i) {
                EXPECT_NEAR(a[i] / std::sqrt(na), b[i] / std::sqrt(nb), 1e-12);
                EXPECT_NEAR(framed.viewUp[i], spec.viewUp[i], 1e-12);
            }
        }
}

TEST(Framing, AxisViewsAndBadNames) {
    const ViewDirection px = parseViewDirection("+x");
    EXPECT_EQ(px.look, (Vec3{1, 0, 0}));
    EXPECT_EQ(px.up, (Vec3{0, 0, 1}));
    EXPECT_EQ(parseViewDirection("-Y").look, (Vec3{0, -1, 0}));
    EXPECT_EQ(parseViewDirection("+z").up, (Vec3{0, 1, 0}));
    EXPECT_EQ(parseViewDirection("x").look, px.look);  // the sign may be left out
    EXPECT_THROW(parseViewDirection("xx"), UdvrError);
    EXPECT_THROW(parseViewDirection("+w"), UdvrError);
    EXPECT_THROW(framedCamera({0, 1, 0, 1, 0, 1}, px, 0, 0, 0.0, 30, 1), UdvrError);
}

// `--view`/`--frame`'s turn: the front view gets SPEC §5's three-quarter turn, an axis view
// none; a given angle replaces it.
TEST(Framing, TheNamedViewsTurnAsTheCliSays) {
    const std::array<double, 6> box{0, 2, 0, 1, 0, 3};
    const auto same = [](const Camera& a, const Camera& b) {
        for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(a.position[k], b.position[k], 1e-12);
            EXPECT_NEAR(a.viewUp[k], b.viewUp[k], 1e-12);
        }
    };
    same(framedCamera(box, "", std::nullopt, std::nullopt, 1.5, 25, 2),
         framedCamera(box, kZUpFrontView, kDefaultAzimuthDeg, kDefaultElevationDeg, 1.5, 25, 2));
    same(framedCamera(box, "-y", std::nullopt, 10.0, 1, 30, 1),
         framedCamera(box, parseViewDirection("-y"), 0, 10, 1, 30, 1));
    same(framedCamera(box, "", 5.0, std::nullopt, 1, 30, 1),
         framedCamera(box, kZUpFrontView, 5, kDefaultElevationDeg, 1, 30, 1));
    EXPECT_THROW(framedCamera(box, "+w", std::nullopt, std::nullopt, 1, 30, 1), UdvrError);
}

TEST(Framing, VisibleBoundsAreThePaddedBoxOfTheVisiblePoints) {
    ModelVolume m;
    m.grid.dims = {10, 8, 6};
    m.grid.origin = {1.0, 0.0, -3.0};
    m.grid.spacing = {0.5, 1.0, 2.0};
    m.bounds = {1.0, 5.5, 0.0, 7.0, -3.0, 7.0};
    m.mean.assign(m.grid.pointCount(), 0.0f);
    m.mean[m.grid.index(3, 2, 1)] = 5.0f;
    m.mean[m.grid.index(4, 7, 2)] = 6.0f;
    m.mean[m.grid.index(0, 0, 0)] = 9.0f;   // outside the visible range
    m.mean[m.grid.index(9, 0, 5)] = 3.05f;  // α 0.01: below 10 % of the peak, fog
    TransferFunction1D tf;
    tf.colorX = {0.0};
    tf.color = {{1.0, 1.0, 1.0}};
    tf.opacityX = {3.0, 4.0, 7.0, 8.0};
    tf.opacity = {0.0, 0.2, 0.2, 0.0};
    const auto box = visibleBounds(m, tf);
    // i 3..4 → x 1+0.5·(2..5); j 2..7 → y 1..7 (clipped); k 1..2 → z −3+2·(0..3).
    const std::array<double, 6> want{2.0, 3.5, 1.0, 7.0, -3.0, 3.0};
    for (int a = 0; a < 6; ++a) EXPECT_DOUBLE_EQ(box[a], want[a]) << a;
    // The same through a 2D TF whose rows differ: the largest α over y decides.
    const TransferFunction2D tf2 = transferFunction2DFrom1D(tf, 9, 0.0, 8.0);
    EXPECT_EQ(visibleBounds(m, tf2), box);
    tf.opacity = {0.0, 0.0, 0.0, 0.0};
    EXPECT_EQ(visibleBounds(m, tf), m.bounds);
}

TEST(Framing, StrayVisiblePointsDoNotStretchTheBox) {
    ModelVolume m;
    m.grid.dims = {40, 40, 40};
    m.bounds = {0, 39, 0, 39, 0, 39};
    m.mean.assign(m.grid.pointCount(), 0.0f);
    for (int k = 10; k < 20; ++k)  // a 10³ block: 1000 visible points
        for (int j = 10; j < 20; ++j)
            for (int i = 10; i < 20; ++i) m.mean[m.grid.index(i, j, k)] = 1.0f;
    m.mean[m.grid.index(39, 39, 39)] = 1.0f;  // one stray point: 0.1 % of them
    TransferFunction1D tf;
    tf.colorX = {0.0};
    tf.color = {{1.0, 1.0, 1.0}};
    tf.opacityX = {0.5, 1.0};
    tf.opacity = {0.0, 1.0};
    const std::array<double, 6> want{9, 20, 9, 20, 9, 20};
    EXPECT_EQ(visibleBounds(m, tf), want);
}

}  // namespace
}  // namespace udvr
