#include "udvr/render/framing.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "udvr/util/check.h"

namespace udvr {
namespace {

using Vec3 = std::array<double, 3>;
constexpr double kPi = 3.14159265358979323846;

double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3 cross(const Vec3& a, const Vec3& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec3 negated(const Vec3& a) { return {-a[0], -a[1], -a[2]}; }
Vec3 combine(const Vec3& a, double sa, const Vec3& b, double sb) {
    return {a[0] * sa + b[0] * sb, a[1] * sa + b[1] * sb, a[2] * sa + b[2] * sb};
}

}  // namespace

ViewDirection parseViewDirection(const std::string& given) {
    const std::string text = given.size() == 1 ? "+" + given : given;  // "x" = "+x"
    const double sign = text.size() == 2 && text[0] == '-' ? -1.0 : 1.0;
    if (text.size() == 2 && (text[0] == '+' || text[0] == '-')) {
        if (text[1] == 'x' || text[1] == 'X') return {{sign, 0, 0}, {0, 0, 1}};
        if (text[1] == 'y' || text[1] == 'Y') return {{0, sign, 0}, {0, 0, 1}};
        if (text[1] == 'z' || text[1] == 'Z') return {{0, 0, sign}, {0, 1, 0}};
    }
    UDVR_FAIL(
        "--view must be one of +x, -x, +y, -y, +z, -z (the direction the camera looks "
        "along), got '"
        << given << "'");
}

Camera framedCamera(const std::array<double, 6>& box, const std::string& view,
                    std::optional<double> azimuthDeg, std::optional<double> elevationDeg,
                    double zoom, double viewAngleDeg, double aspect) {
    const bool front = view.empty();
    return framedCamera(box, front ? kZUpFrontView : parseViewDirection(view),
                        azimuthDeg.value_or(front ? kDefaultAzimuthDeg : 0.0),
                        elevationDeg.value_or(front ? kDefaultElevationDeg : 0.0), zoom,
                        viewAngleDeg, aspect);
}

Camera framedCamera(const std::array<double, 6>& box, const ViewDirection& view, double azimuthDeg,
                    double elevationDeg, double zoom, double viewAngleDeg, double aspect) {
    if (!(zoom > 0.0) || !std::isfinite(zoom)) UDVR_FAIL("--zoom must be > 0, got " << zoom);
    if (!(viewAngleDeg > 0.0 && viewAngleDeg < 180.0))
        UDVR_FAIL("--view-angle must be in (0, 180) degrees, got " << viewAngleDeg);
    UDVR_CHECK(aspect > 0.0);
    // Unit vector from the focal point to the camera, turned as VTK's Azimuth then Elevation.
    const Vec3 up0 = view.up;
    const Vec3 toEye0 = negated(view.look);
    const double a = azimuthDeg * kPi / 180.0, e = elevationDeg * kPi / 180.0;
    const Vec3 toEyeA = combine(toEye0, std::cos(a), cross(up0, toEye0), std::sin(a));
    const Vec3 toEye = combine(toEyeA, std::cos(e), up0, std::sin(e));
    const Vec3 up = combine(up0, std::cos(e), toEyeA, -std::sin(e));
    const Vec3 forward = negated(toEye);
    const Vec3 right = cross(forward, up);

    const double t = std::tan(0.5 * viewAngleDeg * kPi / 180.0) * (1.0 - 0.05);
    const auto corner = [&](int k) {
        return Vec3{box[k & 1], box[2 + ((k >> 1) & 1)], box[4 + ((k >> 2) & 1)]};
    };
    // The distance from focal point c at which every corner fits the 95 % frame.
    const auto fitDistance = [&](const Vec3& c) {
        double d = 0.0;
        for (int k = 0; k < 8; ++k) {
            const Vec3 r = combine(corner(k), 1.0, c, -1.0);
            const double depth = dot(r, forward);  // beyond the focal plane when > 0
            d = std::max(d, std::abs(dot(r, up)) / t - depth);
            d = std::max(d, std::abs(dot(r, right)) / (t * aspect) - depth);
            d = std::max(d, -depth * 1.01);  // the camera stays outside the box
        }
        return d > 0.0 ? d : 1.0;  // an empty box: any distance frames it
    };
    // Start at the box centre, then move the focal point across the view so the projected box
    // is centred (a turned perspective view of a box is not centred on the box's centre); a few
    // rounds settle it to a fraction of a pixel.
    Vec3 c{0.5 * (box[0] + box[1]), 0.5 * (box[2] + box[3]), 0.5 * (box[4] + box[5])};
    double dist = fitDistance(c);
    for (int round = 0; round < 4; ++round) {
        double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};
        for (int k = 0; k < 8; ++k) {
            const Vec3 r = combine(corner(k), 1.0, c, -1.0);
            const double depth = dist + dot(r, forward);
            const double xy[2] = {dot(r, right) / depth, dot(r, up) / depth};
            for (int a2 = 0; a2 < 2; ++a2)
                lo[a2] = std::min(lo[a2], xy[a2]), hi[a2] = std::max(hi[a2], xy[a2]);
        }
        c = combine(c, 1.0, right, 0.5 * (lo[0] + hi[0]) * dist);
        c = combine(c, 1.0, up, 0.5 * (lo[1] + hi[1]) * dist);
        dist = fitDistance(c);
    }
    dist /= zoom;
    Camera cam;
    cam.focalPoint = c;
    cam.position = combine(c, 1.0, toEye, dist);
    cam.viewUp = up;
    cam.viewAngleDeg = viewAngleDeg;
    cam.parallel = false;
    cam.parallelScale = 0.5 * (box[3] - box[2]);
    return cam;
}

std::array<double, 6> visibleBounds(const ModelVolume& model, const TransferFunction1D& tf,
                                    bool* anyVisible) {
    double peak = 0.0;
    for (double a : tf.opacity) peak = std::max(peak, a);
    const double threshold = kVisibleOpacityShare * peak;
    const Grid3& g = model.grid;
    const auto& d = g.dims;
    // Visible points counted per plane along each axis; the box keeps all but the outer
    // kVisibleTrim of them on each side, so scattered noise does not stretch it.
    std::array<std::vector<std::size_t>, 3> perPlane;
    for (int a = 0; a < 3; ++a) perPlane[a].assign(static_cast<std::size_t>(d[a]), 0);
    std::size_t total = 0, idx = 0;
    for (int k = 0; k < d[2]; ++k)
        for (int j = 0; j < d[1]; ++j)
            for (int i = 0; i < d[0]; ++i, ++idx) {
                if (!(peak > 0.0) || tf.opacityAt(model.mean[idx]) < threshold) continue;
                ++perPlane[0][i], ++perPlane[1][j], ++perPlane[2][k], ++total;
            }
    if (anyVisible != nullptr) *anyVisible = total > 0;
    if (total == 0) return model.bounds;
    const auto trimmed = static_cast<std::size_t>(kVisibleTrim * static_cast<double>(total));
    std::array<double, 6> box{};
    for (int a = 0; a < 3; ++a) {
        int lo = 0, hi = d[a] - 1;
        for (std::size_t seen = 0; (seen += perPlane[a][lo]) <= trimmed && lo < hi;) ++lo;
        for (std::size_t seen = 0; (seen += perPlane[a][hi]) <= trimmed && hi > lo;) --hi;
        const double s = g.spacing[a];
        box[2 * a] = std::max(model.bounds[2 * a], g.origin[a] + (lo - 1) * s);
        box[2 * a + 1] = std::min(model.bounds[2 * a + 1], g.origin[a] + (hi + 1) * s);
        if (!(box[2 * a] < box[2 * a + 1])) {  // a flat axis: keep the model's extent
            box[2 * a] = model.bounds[2 * a];
            box[2 * a + 1] = model.bounds[2 * a + 1];
        }
    }
    return box;
}

std::array<double, 6> visibleBounds(const ModelVolume& model, const TransferFunction2D& tf,
                                    bool* anyVisible) {
    TransferFunction1D envelope;  // α(x) = max over the rows; colour unused
    envelope.colorX = {tf.x0};
    envelope.color = {{0.0, 0.0, 0.0}};
    for (int i = 0; i < tf.width; ++i) {
        double a = 0.0;
        for (int j = 0; j < tf.height; ++j) a = std::max(a, static_cast<double>(tf.point(i, j)[3]));
        envelope.opacityX.push_back(tf.x0 + (tf.x1 - tf.x0) * i / (tf.width - 1));
        envelope.opacity.push_back(a);
    }
    return visibleBounds(model, envelope, anyVisible);
}

}  // namespace udvr
