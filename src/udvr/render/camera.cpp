#include "udvr/render/camera.h"

#include <cmath>
#include <limits>
#include <utility>

#include "udvr/util/check.h"

namespace udvr {
namespace {

using Vec3 = std::array<double, 3>;

constexpr double kPi = 3.14159265358979323846;

Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 cross(const Vec3& a, const Vec3& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double norm(const Vec3& a) { return std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]); }
Vec3 scaled(const Vec3& a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }

}  // namespace

Camera defaultCamera(const std::array<double, 6>& bounds, double azimuthDeg, double elevationDeg,
                     double zoom, double viewAngleDeg) {
    if (!(zoom > 0.0) || !std::isfinite(zoom)) UDVR_FAIL("--zoom must be > 0, got " << zoom);
    if (!(viewAngleDeg > 0.0 && viewAngleDeg < 180.0))
        UDVR_FAIL("--view-angle must be in (0, 180) degrees, got " << viewAngleDeg);
    const Vec3 c{0.5 * (bounds[0] + bounds[1]), 0.5 * (bounds[2] + bounds[3]),
                 0.5 * (bounds[4] + bounds[5])};
    const Vec3 extent{bounds[1] - bounds[0], bounds[3] - bounds[2], bounds[5] - bounds[4]};
    const double radius = 0.5 * norm(extent);  // bounding sphere, world units
    const double dist = radius / std::sin(0.5 * viewAngleDeg * kPi / 180.0) / zoom;
    // Start on +z looking −z, up +y. VTK's Azimuth(a) rotates the position about the view-up
    // (+y) through the focal point: direction (sin a, 0, cos a). Elevation(e) then rotates
    // about −(view sideways) = −(cos a, 0, −sin a), which lifts the direction to
    // (sin a cos e, sin e, cos a cos e) and the view-up to (−sin a sin e, cos e, −cos a sin e)
    // (what OrthogonalizeViewUp returns afterwards, valid even at e = ±90°).
    const double a = azimuthDeg * kPi / 180.0, e = elevationDeg * kPi / 180.0;
    const Vec3 d{std::sin(a) * std::cos(e), std::sin(e), std::cos(a) * std::cos(e)};
    Camera cam;
    cam.focalPoint = c;
    cam.position = {c[0] + dist * d[0], c[1] + dist * d[1], c[2] + dist * d[2]};
    cam.viewUp = {-std::sin(a) * std::sin(e), std::cos(e), -std::cos(a) * std::sin(e)};
    cam.viewAngleDeg = viewAngleDeg;
    cam.parallel = false;
    cam.parallelScale = radius;
    return cam;
}

CameraFrame makeCameraFrame(const Camera& camera, int width, int height) {
    if (width < 1 || height < 1)
        UDVR_FAIL("image size must be at least 1x1, got " << width << "x" << height);
    CameraFrame f;
    f.eye = camera.position;
    const Vec3 vpn = sub(camera.position, camera.focalPoint);  // view plane normal (toward eye)
    const double dn = norm(vpn);
    if (!(dn > 0.0) || !std::isfinite(dn))
        UDVR_FAIL("camera position and focal point must differ (both at "
                  << camera.position[0] << "," << camera.position[1] << "," << camera.position[2]
                  << ")");
    const Vec3 n = scaled(vpn, 1.0 / dn);
    Vec3 side = cross(camera.viewUp, n);  // VTK: viewSideways = viewUp × viewPlaneNormal
    const double ds = norm(side);
    if (!(ds > 1e-12 * norm(camera.viewUp)) || !std::isfinite(ds))
        UDVR_FAIL("camera view-up must not be parallel to the view direction");
    f.right = scaled(side, 1.0 / ds);
    f.up = cross(n, f.right);  // VTK: orthoViewUp = viewPlaneNormal × viewSideways
    f.forward = scaled(n, -1.0);
    f.parallel = camera.parallel;
    if (camera.parallel) {
        if (!(camera.parallelScale > 0.0) || !std::isfinite(camera.parallelScale))
            UDVR_FAIL("--parallel-scale must be > 0, got " << camera.parallelScale);
        f.halfHeight = camera.parallelScale;
    } else {
        if (!(camera.viewAngleDeg > 0.0 && camera.viewAngleDeg < 180.0))
            UDVR_FAIL("--view-angle must be in (0, 180) degrees, got " << camera.viewAngleDeg);
        f.halfHeight = std::tan(0.5 * camera.viewAngleDeg * kPi / 180.0);
    }
    f.width = width;
    f.height = height;
    f.aspect = static_cast<double>(width) / static_cast<double>(height);
    return f;
}

void CameraFrame::ray(int px, int py, std::array<double, 3>& origin,
                      std::array<double, 3>& dir) const {
    // Normalised device coordinates of the pixel centre: x right, y up, both in (−1, 1).
    const double u = (2.0 * (px + 0.5) / width - 1.0) * aspect * halfHeight;
    const double v = (1.0 - 2.0 * (py + 0.5) / height) * halfHeight;
    if (parallel) {
        for (int a = 0; a < 3; ++a) {
            origin[a] = eye[a] + u * right[a] + v * up[a];
            dir[a] = forward[a];
        }
        return;
    }
    origin = eye;
    Vec3 d{forward[0] + u * right[0] + v * up[0], forward[1] + u * right[1] + v * up[1],
           forward[2] + u * right[2] + v * up[2]};
    const double inv = 1.0 / norm(d);
    dir = scaled(d, inv);
}

bool intersectBox(const std::array<double, 6>& bounds, const std::array<double, 3>& origin,
                  const std::array<double, 3>& dir, double& tNear, double& tFar) {
    double t0 = -std::numeric_limits<double>::infinity();
    double t1 = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a) {
        const double lo = bounds[2 * a], hi = bounds[2 * a + 1];
        if (dir[a] == 0.0) {
            if (origin[a] < lo || origin[a] > hi) return false;
            continue;
        }
        const double inv = 1.0 / dir[a];
        double ta = (lo - origin[a]) * inv, tb = (hi - origin[a]) * inv;
        if (ta > tb) std::swap(ta, tb);
        if (ta > t0) t0 = ta;
        if (tb < t1) t1 = tb;
    }
    tNear = t0;
    tFar = t1;
    return t0 <= t1;
}

}  // namespace udvr
