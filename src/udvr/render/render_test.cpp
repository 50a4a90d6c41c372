#include "udvr/render/render.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "udvr/classify/expected_tf.h"
#include "udvr/classify/model_kind.h"
#include "udvr/classify/tf_pieces.h"
#include "udvr/classify/tf_presets.h"
#include "udvr/data/synthetic.h"
#include "udvr/render/camera.h"
#include "udvr/render/ray_march.h"
#include "udvr/stats/model_volume.h"
#include "udvr/util/parallel.h"

namespace udvr {
namespace {

constexpr double kPi = 3.14159265358979323846;
using V3 = std::array<double, 3>;

TransferFunction1D constantTf(double alpha, std::array<double, 3> rgb) {
    TransferFunction1D tf;
    tf.colorX = {0.0, 1.0};
    tf.color = {rgb, rgb};
    tf.opacityX = {0.0, 1.0};
    tf.opacity = {alpha, alpha};
    return tf;
}

ModelVolume constantModel(int n, float value, double spacing = 1.0) {
    ScalarField f;
    f.grid.dims = {n, n, n};
    f.grid.spacing = {spacing, spacing, spacing};
    f.grid.origin = {-0.5 * spacing * (n - 1), 0.0, 1.0};
    f.values.assign(f.grid.pointCount(), value);
    return modelFromField(f);
}

double maxAbsDiff(const ImageRgba& a, const ImageRgba& b) {
    EXPECT_EQ(a.rgba.size(), b.rgba.size());
    double m = 0.0;
    for (std::size_t i = 0; i < a.rgba.size(); ++i)
        m = std::max(m, std::abs(static_cast<double>(a.rgba[i]) - b.rgba[i]));
    return m;
}

V3 rotate(const V3& v, const V3& axisIn, double deg) {  // Rodrigues, right-handed
    const double n =
        std::sqrt(axisIn[0] * axisIn[0] + axisIn[1] * axisIn[1] + axisIn[2] * axisIn[2]);
    const V3 k{axisIn[0] / n, axisIn[1] / n, axisIn[2] / n};
    const double t = deg * kPi / 180.0, c = std::cos(t), s = std::sin(t);
    const double kv = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
    const V3 kxv{k[1] * v[2] - k[2] * v[1], k[2] * v[0] - k[0] * v[2], k[0] * v[1] - k[1] * v[0]};
    V3 r;
    for (int i = 0; i < 3; ++i) r[i] = v[i] * c + kxv[i] * s + k[i] * kv * (1 - c);
    return r;
}
V3 cross3(const V3& a, const V3& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
V3 normalized(const V3& a) {
    const double n = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    return {a[0] / n, a[1] / n, a[2] / n};
}

TEST(RenderCamera, DefaultCameraMatchesVtkAzimuthElevation) {
    const std::array<double, 6> b{-2.5, 2.5, -1.0, 3.0, 0.0, 2.0};
    const V3 c{0.0, 1.0, 1.0};
    const double radius = 0.5 * std::sqrt(25.0 + 16.0 + 4.0);
    for (double az : {0.0, 30.0, -75.0, 200.0})
        for (double el : {0.0, 20.0, -40.0, 89.0}) {
            for (double zoom : {1.0, 1.7}) {
                // vtk_render.py: position on +z at the distance where the sphere fits 30°.
                const double dist = radius / std::sin(15.0 * kPi / 180.0) / zoom;
                V3 rel{0.0, 0.0, dist};
                V3 up{0.0, 1.0, 0.0};
                // vtkCamera::Azimuth: rotate the position about the view-up through the focal
                // point.
                rel = rotate(rel, up, az);
                // vtkCamera::Elevation: about −(row 0 of the view matrix) = −(up × vpn).
                const V3 side = normalized(cross3(up, normalized(rel)));
                const V3 axis{-side[0], -side[1], -side[2]};
                rel = rotate(rel, axis, el);
                // OrthogonalizeViewUp: row 1 of the view matrix built with the rotated up.
                const V3 upRot = rotate(up, axis, el);
                const V3 vpn = normalized(rel);
                const V3 ortho = cross3(vpn, normalized(cross3(upRot, vpn)));
                const Camera cam = defaultCamera(b, az, el, zoom, 30.0);
                for (int i = 0; i < 3; ++i) {
                    EXPECT_NEAR(cam.position[i], c[i] + rel[i], 1e-9) << az << " " << el;
                    EXPECT_NEAR(cam.focalPoint[i], c[i], 1e-12);
                    const CameraFrame f = makeCameraFrame(cam, 8, 8);
                    EXPECT_NEAR(f.up[i], ortho[i], 1e-9) << az << " " << el;
                }
            }
        }
}

TEST(RenderCamera, DefaultCameraOfPeerTangle64) {
    // vtk_render.py's JSON for the 64³ tangle (VTK 9.1), azimuth 30, elevation 20, view angle 30:
    // position 7.860681982453917 5.722108525591003 13.615100574946178,
    // view-up −0.17101007166283438 0.9396926207859084 −0.2961981327260239.
    const Camera cam = defaultCamera({-2.5, 2.5, -2.5, 2.5, -2.5, 2.5}, 30.0, 20.0);
    const double dist = std::sqrt(3.0) * 2.5 / std::sin(15.0 * kPi / 180.0);
    EXPECT_NEAR(cam.position[0], dist * std::sin(kPi / 6) * std::cos(kPi / 9), 1e-9);
    EXPECT_NEAR(cam.position[1], dist * std::sin(kPi / 9), 1e-9);
    EXPECT_NEAR(cam.position[2], dist * std::cos(kPi / 6) * std::cos(kPi / 9), 1e-9);
    // VTK's bounds come from float32 spacing, hence the 1e-8-level differences.
    EXPECT_NEAR(cam.position[0], 7.860681982453917, 1e-7);
    EXPECT_NEAR(cam.position[1], 5.722108525591003, 1e-7);
    EXPECT_NEAR(cam.position[2], 13.615100574946178, 1e-7);
    EXPECT_NEAR(cam.viewUp[0], -0.17101007166283438, 1e-12);
    EXPECT_NEAR(cam.viewUp[1], 0.9396926207859084, 1e-12);
    EXPECT_NEAR(cam.viewUp[2], -0.2961981327260239, 1e-12);
}

TEST(RenderCamera, DegenerateCamerasAreUserErrors) {
    Camera c;
    c.position = c.focalPoint;
    EXPECT_THROW(makeCameraFrame(c, 4, 4), UdvrError);
    c = Camera{};
    c.viewUp = {0, 0, 2};  // parallel to the view direction
    EXPECT_THROW(makeCameraFrame(c, 4, 4), UdvrError);
    c = Camera{};
    c.viewAngleDeg = 180.0;
    EXPECT_THROW(makeCameraFrame(c, 4, 4), UdvrError);
}

// Beer–Lambert on a constant field: every sample has E[α] = α, so after N samples the
// accumulated opacity is 1 − (1 − α)^(N·Δ/u) and the colour c times that.
TEST(Render, ConstantFieldMatchesBeerLambert) {
    const ModelVolume m = constantModel(6, 0.5f, 0.8);  // box [-2,2]×[0,4]×[1,5]
    const double alpha = 0.3, step = 0.37, unit = 0.9;
    const std::array<double, 3> rgb{0.2, 0.5, 0.8};
    const std::array<float, 3> bg{0.1f, 0.9f, 0.3f};
    RenderSettings s;
    s.width = 23;
    s.height = 17;
    s.camera = defaultCamera(m.bounds, 35.0, 25.0, 1.3);
    s.step = step;
    s.unitDistance = unit;
    s.earlyExit = 1.0;
    s.background = bg;
    const ImageRgba img = renderVolume(m, ModelKind::Mean, constantTf(alpha, rgb), s);

    // Independent rays: pixel centres, vertical view angle, top-left origin.
    const V3 eye = s.camera.position;
    const V3 fwd = normalized({s.camera.focalPoint[0] - eye[0], s.camera.focalPoint[1] - eye[1],
                               s.camera.focalPoint[2] - eye[2]});
    const V3 right = normalized(cross3(fwd, s.camera.viewUp));
    const V3 up = cross3(right, fwd);
    const double th = std::tan(s.camera.viewAngleDeg * kPi / 360.0);
    int hits = 0;
    for (int py = 0; py < s.height; ++py)
        for (int px = 0; px < s.width; ++px) {
            const double u = ((px + 0.5) / s.width * 2 - 1) * th * s.width / s.height;
            const double v = (1 - (py + 0.5) / s.height * 2) * th;
            V3 d;
            for (int i = 0; i < 3; ++i) d[i] = fwd[i] + u * right[i] + v * up[i];
            d = normalized(d);
            double t0 = -1e300, t1 = 1e300;
            for (int a = 0; a < 3; ++a) {
                double ta = (m.bounds[2 * a] - eye[a]) / d[a],
                       tb = (m.bounds[2 * a + 1] - eye[a]) / d[a];
                t0 = std::max(t0, std::min(ta, tb));
                t1 = std::min(t1, std::max(ta, tb));
            }
            double n = 0;
            if (t1 > t0) {
                const double steps = (t1 - t0) / step - 0.5;
                if (steps >= 0) {
                    const double frac = steps - std::floor(steps);
                    if (frac < 1e-6 || frac > 1 - 1e-6) continue;  // count ambiguous at rounding
                    n = std::floor(steps) + 1;
                }
            }
            if (n > 0) ++hits;
            const double a = 1 - std::pow(1 - alpha, n * step / unit);
            const float* p = img.pixel(px, py);
            for (int ch = 0; ch < 3; ++ch)
                EXPECT_NEAR(p[ch], rgb[ch] * a + (1 - a) * bg[ch], 2e-6) << px << "," << py;
            EXPECT_NEAR(p[3], a, 2e-6) << px << "," << py;
        }
    EXPECT_GT(hits, 50);
}

TEST(Render, EarlyTerminationStopsAfterThreshold) {
    const ModelVolume m = constantModel(8, 0.5f);
    RenderSettings s;
    s.width = s.height = 9;
    s.camera = defaultCamera(m.bounds, 0.0, 0.0);
    s.step = 0.5;
    s.unitDistance = 0.5;  // α' = α
    s.earlyExit = 0.9;
    const ImageRgba img = renderVolume(m, ModelKind::Mean, constantTf(0.5, {1, 1, 1}), s);
    // 1 − 0.5^k first exceeds 0.9 at k = 4: 0.9375; the centre ray has 14 samples.
    EXPECT_NEAR(img.pixel(4, 4)[3], 0.9375, 1e-6);
}

TEST(Render, CameraThatMissesGivesExactlyTheBackground) {
    const ModelVolume m = constantModel(5, 0.5f);
    RenderSettings s;
    s.width = s.height = 12;
    s.camera = defaultCamera(m.bounds, 0.0, 0.0);
    // Look away from the volume.
    for (int i = 0; i < 3; ++i)
        s.camera.focalPoint[i] = 2 * s.camera.position[i] - s.camera.focalPoint[i];
    s.background = {0.25f, 0.5f, 0.75f};
    RenderStats st;
    const ImageRgba img = renderVolume(m, ModelKind::Mean, constantTf(1.0, {1, 0, 0}), s, &st);
    for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width; ++x) {
            const float* p = img.pixel(x, y);
            EXPECT_EQ(p[0], 0.25f);
            EXPECT_EQ(p[1], 0.5f);
            EXPECT_EQ(p[2], 0.75f);
            EXPECT_EQ(p[3], 0.f);
        }
    EXPECT_EQ(st.samples, 0u);
}

TEST(Render, PixelZeroIsTopLeft) {
    // Value = world y + x/10: high y should be at the top, high x on the right (az 0, el 0).
    ScalarField f;
    f.grid.dims = {9, 9, 9};
    f.values.resize(f.grid.pointCount());
    for (int k = 0; k < 9; ++k)
        for (int j = 0; j < 9; ++j)
            for (int i = 0; i < 9; ++i) f.values[f.grid.index(i, j, k)] = float(j);
    TransferFunction1D tf;
    tf.colorX = {0, 8};
    tf.color = {{0, 0, 1}, {1, 0, 0}};
    tf.opacityX = {0, 8};
    tf.opacity = {0.5, 0.5};
    RenderSettings s;
    s.width = s.height = 16;
    s.camera = defaultCamera(f.grid.bounds(), 0.0, 0.0, 1.5);
    const ImageRgba img = renderVolume(modelFromField(f), ModelKind::Mean, tf, s);
    EXPECT_GT(img.pixel(8, 4)[0], img.pixel(8, 4)[2]);    // top: red
    EXPECT_LT(img.pixel(8, 11)[0], img.pixel(8, 11)[2]);  // bottom: blue
    // Right = +x: at azimuth 90 the camera sits on +x, so image-right is −z.
    const Camera side = defaultCamera(f.grid.bounds(), 90.0, 0.0);
    const CameraFrame fr = makeCameraFrame(side, 4, 4);
    EXPECT_NEAR(fr.right[2], -1.0, 1e-12);
    EXPECT_NEAR(makeCameraFrame(defaultCamera(f.grid.bounds(), 0, 0), 4, 4).right[0], 1.0, 1e-12);
}

TEST(Render, OrthographicAndPerspectiveAgreeOnTheAxisRay) {
    const ModelVolume m = constantModel(7, 0.5f);  // box 6 wide
    const auto tf = constantTf(0.2, {0.3, 0.6, 0.9});
    RenderSettings s;
    s.width = s.height = 15;  // odd: pixel (7,7) is the optical axis
    s.camera = defaultCamera(m.bounds, 0.0, 0.0);
    s.earlyExit = 1.0;
    const ImageRgba persp = renderVolume(m, ModelKind::Mean, tf, s);
    s.camera.parallel = true;
    s.camera.parallelScale = 5.0;  // 10 world units tall: box covers pixels with |u| < 3
    const ImageRgba ortho = renderVolume(m, ModelKind::Mean, tf, s);
    for (int ch = 0; ch < 4; ++ch) EXPECT_NEAR(persp.pixel(7, 7)[ch], ortho.pixel(7, 7)[ch], 1e-6);
    // Orthographic: every pixel inside the box's footprint sees the same depth 6.
    for (int y = 0; y < 15; ++y)
        for (int x = 0; x < 15; ++x) {
            const double u = ((x + 0.5) / 15 * 2 - 1) * 5, v = (1 - (y + 0.5) / 15 * 2) * 5;
            const bool inside = std::abs(u) < 3 && std::abs(v) < 3;
            if (inside) {
                EXPECT_NEAR(ortho.pixel(x, y)[3], ortho.pixel(7, 7)[3], 1e-6);
            } else if (std::abs(u) > 3.01 || std::abs(v) > 3.01) {
                EXPECT_EQ(ortho.pixel(x, y)[3], 0.f);
            }
        }
    // Perspective: off-axis rays through the near face are longer or miss; the corner misses.
    EXPECT_EQ(persp.pixel(0, 0)[3], 0.f);
}

ModelVolume tangleModel(int n) { return modelFromField(makeTangle(n, n, n)); }

TEST(Render, EmptySpaceSkippingDoesNotChangeTheImage) {
    const ModelVolume m = tangleModel(40);
    RenderSettings s;
    s.width = s.height = 48;
    s.camera = defaultCamera(m.bounds, 30.0, 20.0);
    RenderStats on, off;
    const auto tf = tangleTransferFunction();
    const ImageRgba a = renderVolume(m, ModelKind::Mean, tf, s, &on);
    s.skipEmpty = false;
    const ImageRgba b = renderVolume(m, ModelKind::Mean, tf, s, &off);
    EXPECT_LE(maxAbsDiff(a, b), 1e-6);
    EXPECT_GT(on.skippedSamples, 0u);
    EXPECT_EQ(off.skippedSamples, 0u);
    EXPECT_LT(on.samples, off.samples);
    // A TF that is opaque only where the field is below its minimum: everything is skipped.
    TransferFunction1D clear = tf;
    clear.opacityX = {-100, -90};
    clear.opacity = {0, 0};
    s.skipEmpty = true;
    RenderStats st;
    const ImageRgba c = renderVolume(m, ModelKind::Mean, clear, s, &st);
    EXPECT_EQ(st.samples, 0u);
    EXPECT_EQ(c.pixel(24, 24)[0], 1.f);
}

TEST(Render, CacheReusesTablesAndRebuildsForANewTf) {
    const ModelVolume m = tangleModel(24);
    RenderSettings s;
    s.width = s.height = 32;
    s.camera = defaultCamera(m.bounds, 30.0, 20.0);
    RenderCache cache;
    const auto tf = tangleTransferFunction();
    const ImageRgba a = renderVolume(m, ModelKind::Mean, tf, s);
    const ImageRgba b = renderVolume(m, ModelKind::Mean, tf, s, nullptr, &cache);
    s.camera = defaultCamera(m.bounds, -60.0, 10.0);  // new camera: the tables still hold
    const ImageRgba c = renderVolume(m, ModelKind::Mean, tf, s, nullptr, &cache);
    EXPECT_EQ(maxAbsDiff(a, b), 0.0);
    EXPECT_EQ(maxAbsDiff(c, renderVolume(m, ModelKind::Mean, tf, s)), 0.0);
    TransferFunction1D other = tf;  // opaque only in the outer shell: different tables
    other.opacity = {0, 0, 0, 0, 0, 0, 0, 0, 0.3, 0, 0};
    EXPECT_EQ(maxAbsDiff(renderVolume(m, ModelKind::Mean, other, s, nullptr, &cache),
                         renderVolume(m, ModelKind::Mean, other, s)),
              0.0);
}

// 2D TFs: the cache keeps the skipping tables and the grid gradients; every cached frame equals
// the uncached one exactly, across cameras, kinds (the mean's gradients shared) and TF2s.
TEST(Render, CacheServes2DTfsAcrossCamerasKindsAndTfs) {
    ModelVolume m = tangleModel(20);
    // Quantiles: the value ± a spread that varies over the grid, so gradients differ per layer.
    const int q = 4;
    m.quantileCount = q;
    for (std::size_t v = 0; v < m.voxelCount(); ++v)
        for (int j = 0; j <= q; ++j)
            m.quantiles.push_back(m.mean[v] + static_cast<float>(j - 2) *
                                                  (0.2f + 0.01f * static_cast<float>(v % 7)));
    RenderSettings s;
    s.width = s.height = 24;
    s.camera = defaultCamera(m.bounds, 30.0, 20.0);
    TransferFunction2D t;
    t.width = 5;
    t.height = 4;
    t.x0 = -6;
    t.x1 = 6;
    t.y0 = 0;
    t.y1 = 60;
    for (int k = 0; k < t.width * t.height; ++k)
        t.rgba.insert(t.rgba.end(), {0.2f + 0.1f * static_cast<float>(k % 5), 0.5f,
                                     0.9f - 0.05f * static_cast<float>(k % 4),
                                     (k % 3 == 0) ? 0.f : 0.1f * static_cast<float>(k % 9)});
    RenderCache cache;
    for (ModelKind kind : {ModelKind::Mean, ModelKind::QuantileRange, ModelKind::QuantileMean})
        for (double azimuth : {30.0, -60.0}) {
            s.camera = defaultCamera(m.bounds, azimuth, 20.0);
            EXPECT_EQ(maxAbsDiff(renderVolume(m, kind, t, s, nullptr, &cache),
                                 renderVolume(m, kind, t, s)),
                      0.0)
                << modelName(kind) << " azimuth " << azimuth;
        }
    TransferFunction2D other = t;  // α only on the first column: new skipping ranges
    for (int k = 0; k < other.width * other.height; ++k)
        other.rgba[4 * k + 3] = k % other.width == 0 ? 0.5f : 0.f;
    EXPECT_EQ(maxAbsDiff(renderVolume(m, ModelKind::QuantileRange, other, s, nullptr, &cache),
                         renderVolume(m, ModelKind::QuantileRange, other, s)),
              0.0);
}

// 2D TFs skip cells whose values miss the x ranges where the TF2 has α > 0: the same image as
// without skipping, fewer samples.
TEST(Render, EmptySpaceSkippingWithA2DTfDoesNotChangeTheImage) {
    const ModelVolume m = tangleModel(30);
    RenderSettings s;
    s.width = s.height = 32;
    s.camera = defaultCamera(m.bounds, 30.0, 20.0);
    TransferFunction2D t;  // α > 0 only for values in [−1, 2] (columns at −7, −4, …, 35)
    t.width = 15;
    t.height = 3;
    t.x0 = -7;
    t.x1 = 35;
    t.y0 = 0;
    t.y1 = 60;
    for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 15; ++i)
            t.rgba.insert(t.rgba.end(), {0.9f, 0.4f, 0.2f, i == 2 && j > 0 ? 0.6f : 0.f});
    RenderStats on, off;
    const ImageRgba a = renderVolume(m, ModelKind::Mean, t, s, &on);
    s.skipEmpty = false;
    const ImageRgba b = renderVolume(m, ModelKind::Mean, t, s, &off);
    EXPECT_LE(maxAbsDiff(a, b), 1e-6);
    EXPECT_GT(on.skippedSamples, 0u);
    EXPECT_LT(on.samples, off.samples);
    EXPECT_GT(a.pixel(16, 16)[3], 0.f);  // something is drawn
}

TEST(Render, SkippingOnADownsampledGridAndJitter) {
    // A coarse model grid inside the full-resolution box: samples clamp into the grid.
    ModelVolume m = tangleModel(21);
    m.bounds = {-2.7, 2.7, -2.6, 2.6, -2.8, 2.8};
    m.fullResMinSpacing = 0.1;
    RenderSettings s;
    s.width = s.height = 32;
    s.camera = defaultCamera(m.bounds, -40.0, 60.0, 1.2);
    s.jitterSeed = 7;
    const auto tf = tangleTransferFunction();
    const ImageRgba a = renderVolume(m, ModelKind::Mean, tf, s);
    s.skipEmpty = false;
    const ImageRgba b = renderVolume(m, ModelKind::Mean, tf, s);
    EXPECT_LE(maxAbsDiff(a, b), 1e-6);
    s.jitterSeed.reset();
    const ImageRgba c = renderVolume(m, ModelKind::Mean, tf, s);
    EXPECT_GT(maxAbsDiff(a, c), 1e-4);  // jitter moves the samples
}

TEST(Render, ThreadCountDoesNotChangeTheImage) {
    const ModelVolume m = tangleModel(24);
    RenderSettings s;
    s.width = 40;
    s.height = 35;
    s.camera = defaultCamera(m.bounds, 10.0, -30.0);
    setThreadCount(1);
    const ImageRgba a = renderVolume(m, ModelKind::Mean, tangleTransferFunction(), s);
    setThreadCount(2);
    const ImageRgba b = renderVolume(m, ModelKind::Mean, tangleTransferFunction(), s);
    setThreadCount(0);
    EXPECT_EQ(maxAbsDiff(a, b), 0.0);
}

ModelVolume gmmModel(int n, int k) {
    ModelVolume m = tangleModel(n);
    m.gmmComponents = k;
    m.gmm.resize(m.voxelCount() * 3 * k);
    for (std::size_t v = 0; v < m.voxelCount(); ++v) {
        float* g = m.gmm.data() + v * 3 * k;
        for (int c = 0; c < k; ++c) {
            g[c] = 1.f / static_cast<float>(k);
            g[k + c] =
                m.mean[v] + 1.5f * (static_cast<float>(c) - 0.5f * static_cast<float>(k - 1));
            g[2 * k + c] = 0.4f;
        }
    }
    return m;
}

TEST(Render, GmmMcIsDeterministicForASeed) {
    const ModelVolume m = gmmModel(16, 2);
    RenderSettings s;
    s.width = s.height = 24;
    s.camera = defaultCamera(m.bounds, 30.0, 20.0);
    s.realizations = 4;
    s.seed = 11;
    setThreadCount(1);
    const ImageRgba a = renderVolume(m, ModelKind::GmmMc, tangleTransferFunction(), s);
    setThreadCount(2);
    const ImageRgba b = renderVolume(m, ModelKind::GmmMc, tangleTransferFunction(), s);
    setThreadCount(0);
    EXPECT_EQ(maxAbsDiff(a, b), 0.0);
    s.seed = 12;
    const ImageRgba c = renderVolume(m, ModelKind::GmmMc, tangleTransferFunction(), s);
    EXPECT_GT(maxAbsDiff(a, c), 1e-3);
}

TEST(Render, GmmMcWithPointMassesIsTheMeanField) {
    ModelVolume m = gmmModel(16, 3);
    for (std::size_t v = 0; v < m.voxelCount(); ++v) {
        float* g = m.gmm.data() + v * 9;
        for (int c = 0; c < 3; ++c) {
            g[3 + c] = m.mean[v];  // every component at the mean, σ = 0
            g[6 + c] = 0.f;
        }
    }
    RenderSettings s;
    s.width = s.height = 20;
    s.camera = defaultCamera(m.bounds, 30.0, 20.0);
    s.realizations = 3;
    const ImageRgba mc = renderVolume(m, ModelKind::GmmMc, tangleTransferFunction(), s);
    const ImageRgba mean = renderVolume(m, ModelKind::Mean, tangleTransferFunction(), s);
    EXPECT_LE(maxAbsDiff(mc, mean), 1e-6);
}

// Planes k0..k1 of `m` as a model of their own, with the whole model's bounds (a piece a rank
// holds: ParaView's z pieces share their boundary plane).
ModelVolume planesOf(const ModelVolume& m, int k0, int k1) {
    ModelVolume p = m;
    p.grid.dims[2] = k1 - k0 + 1;
    p.grid.origin[2] = m.grid.origin[2] + k0 * m.grid.spacing[2];
    const std::size_t plane = static_cast<std::size_t>(m.grid.dims[0]) * m.grid.dims[1];
    for (const ModelFileArray& a : kModelFileArrays) {
        const std::vector<float>& src = m.*a.values;
        if (src.empty()) continue;
        const std::size_t c = src.size() / m.voxelCount();
        (p.*a.values)
            .assign(src.begin() + static_cast<std::ptrdiff_t>(plane * c * k0),
                    src.begin() + static_cast<std::ptrdiff_t>(plane * c * (k1 + 1)));
    }
    return p;
}

// Two z pieces, each rendered with RenderSettings::piece over a black background, composited
// front over back (the camera is above the split plane, so the upper piece is in front for every
// ray) give the whole model's image: every sample is taken once, where the whole render takes it,
// and gmm-mc draws every voxel as the whole model does. (One realization: an average of R
// composited frames is not the composite of the pieces' averages, so gmm-mc across pieces with
// R > 1 is an approximation.)
TEST(Render, PiecesCompositedInVisibilityOrderAreTheWholeImage) {
    const ModelVolume m = gmmModel(21, 2);
    const int split = 9;
    const ModelVolume lower = planesOf(m, 0, split), upper = planesOf(m, split, 20);
    RenderSettings s;
    s.width = s.height = 40;
    s.camera = defaultCamera(m.bounds, 30.0, 20.0);
    s.background = {0.f, 0.f, 0.f};
    s.earlyExit = 1.0;  // a piece stops on its own α; without early exit the sum is exact
    s.realizations = 1;
    const auto tf = tangleTransferFunction();
    const double zSplit = m.grid.origin[2] + split * m.grid.spacing[2];
    ASSERT_GT(s.camera.position[2], zSplit);
    for (ModelKind kind : {ModelKind::Mean, ModelKind::GmmOrdered, ModelKind::GmmMc}) {
        SCOPED_TRACE(std::string(modelName(kind)));
        const ImageRgba whole = renderVolume(m, kind, tf, s);
        RenderSettings sl = s, su = s;
        sl.piece =
            RenderPiece{{m.bounds[0], m.bounds[1], m.bounds[2], m.bounds[3], m.bounds[4], zSplit},
                        {0, 0, 0},
                        m.grid.dims};
        su.piece =
            RenderPiece{{m.bounds[0], m.bounds[1], m.bounds[2], m.bounds[3], zSplit, m.bounds[5]},
                        {0, 0, split},
                        m.grid.dims};
        const ImageRgba back = renderVolume(lower, kind, tf, sl);
        const ImageRgba front = renderVolume(upper, kind, tf, su);
        ImageRgba over = front;
        for (std::size_t i = 0; i < over.rgba.size(); i += 4)
            for (int c = 0; c < 4; ++c)
                over.rgba[i + c] = front.rgba[i + c] + (1.f - front.rgba[i + 3]) * back.rgba[i + c];
        EXPECT_LE(maxAbsDiff(over, whole), 2e-5);
        // Each piece alone is far from the whole: both hold visible samples.
        EXPECT_GT(maxAbsDiff(front, whole), 0.05);
        EXPECT_GT(maxAbsDiff(back, whole), 0.05);
    }
    RenderSettings bad = s;
    bad.piece = RenderPiece{m.bounds, {0, 0, split}, m.grid.dims};  // runs past the whole grid
    EXPECT_THROW(renderVolume(m, ModelKind::Mean, tf, bad), UdvrError);
}

TEST(Render, BadSettingsAreUserErrors) {
    const ModelVolume m = constantModel(4, 0.5f);
    const auto tf = constantTf(0.5, {1, 1, 1});
    RenderSettings s;
    s.width = s.height = 4;
    s.camera = defaultCamera(m.bounds, 0, 0);
    RenderSettings bad = s;
    bad.step = -1;
    EXPECT_THROW(renderVolume(m, ModelKind::Mean, tf, bad), UdvrError);
    bad = s;
    bad.earlyExit = 0;
    EXPECT_THROW(renderVolume(m, ModelKind::Mean, tf, bad), UdvrError);
    bad = s;
    bad.width = 0;
    EXPECT_THROW(renderVolume(m, ModelKind::Mean, tf, bad), UdvrError);
    EXPECT_THROW(renderVolume(m, ModelKind::GmmMc, tf, s), UdvrError);  // no gmm array
}

// The float TF pieces the batched ray loop classifies with, a batch of lanes at a time, against the
// reference evaluator (a step, a colour-only point, clamping at both ends).
TEST(TfPiecesFloat, LanesMatchTheReferenceEvaluator) {
    TransferFunction1D tf = tangleTransferFunction();
    // Add a step (two points at the same x) and an interior colour-only point.
    tf.opacityX = {-3.0, -1.0, 0.1, 0.1, 2.0, 5.0};
    tf.opacity = {0.2, 0.7, 0.1, 0.9, 0.4, 0.0};
    const TfPiecesStorage pieces(tf);
    std::vector<float> xs;
    for (int i = -2000; i <= 4000; ++i) xs.push_back(static_cast<float>(i) * 0.0123f);
    xs.insert(xs.end(), {0.1f, 0.0999f, -1e6f, 1e6f});
    while (xs.size() % lanes::kWidth) xs.push_back(0.f);
    for (std::size_t i = 0; i < xs.size(); i += lanes::kWidth) {
        lanes::Vf got[4];
        tfAt<lanes::Vf>(pieces.fast().sized<kTfSmall>(), lanes::load(&xs[i]), got);
        for (int l = 0; l < lanes::kWidth; ++l) {
            const Rgba want = tf.classify(xs[i + l]);  // premultiplied, at the float x
            EXPECT_NEAR(got[0][l], want.r, 2e-6) << xs[i + l];
            EXPECT_NEAR(got[1][l], want.g, 2e-6) << xs[i + l];
            EXPECT_NEAR(got[2][l], want.b, 2e-6) << xs[i + l];
            EXPECT_NEAR(got[3][l], want.a, 2e-6) << xs[i + l];
        }
    }
    // Right-continuous at the step (0.1f > 0.1), clamped outside.
    float one[4];
    tfAt<float>(pieces.fast(), 0.1f, one);
    EXPECT_NEAR(one[3], 0.9f, 1e-6);
    tfAt<float>(pieces.fast(), -1e6f, one);
    EXPECT_NEAR(one[3], 0.2f, 1e-7);
    tfAt<float>(pieces.fast(), 1e6f, one);
    EXPECT_NEAR(one[3], 0.0f, 1e-7);
}

}  // namespace
}  // namespace udvr
