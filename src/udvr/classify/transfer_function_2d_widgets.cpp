#include "udvr/classify/transfer_function_2d_widgets.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <numbers>
#include <type_traits>

#include "udvr/util/check.h"
#include "udvr/util/parallel.h"

namespace udvr {
namespace {

// Shape factors in [0, 1]; the widget's opacity is a times the factor.

double boxFactor(const Tf2Box& b, double x, double y) {
    return x >= b.x[0] && x <= b.x[1] && y >= b.y[0] && y <= b.y[1] ? 1.0 : 0.0;
}

double triangleFactor(const Tf2Triangle& t, double x, double y) {
    const double s = (y - t.apex[1]) / (t.top - t.apex[1]);  // 0 at the apex, 1 on the top edge
    if (!(s >= 0.0 && s <= 1.0)) return 0.0;
    const double halfWidth = 0.5 * t.width * s;
    const double dx = std::abs(x - t.apex[0]);
    if (dx > halfWidth) return 0.0;
    if (t.flat || halfWidth == 0.0) return 1.0;  // at the apex only x = ax is inside
    return 1.0 - dx / halfWidth;
}

double ellipseFactor(const Tf2Ellipse& e, double x, double y) {
    const double theta = e.angleDeg * std::numbers::pi / 180.0;
    const double c = std::cos(theta), s = std::sin(theta);
    const double dx = x - e.center[0], dy = y - e.center[1];
    const double u = (c * dx + s * dy) / e.sigma[0];   // along the rotated sx axis, in σ
    const double v = (-s * dx + c * dy) / e.sigma[1];  // along the rotated sy axis, in σ
    const double d2 = u * u + v * v;
    if (d2 > e.cutoff * e.cutoff) return 0.0;
    return std::exp(-0.5 * d2);
}

double bandFactor(const Tf2Band& b, double x, double y) {
    // Distances in the plane scaled by the half widths, where the band is 1 wide each side.
    const double px = x / b.halfWidth[0], py = y / b.halfWidth[1];
    double best2 = std::numeric_limits<double>::infinity();
    const std::size_t n = b.points.size();
    for (std::size_t k = 0; k < n; ++k) {
        const double ax = b.points[k][0] / b.halfWidth[0], ay = b.points[k][1] / b.halfWidth[1];
        double qx = ax, qy = ay;  // nearest point of segment k, k+1 (or the lone point)
        if (k + 1 < n) {
            const double ex = b.points[k + 1][0] / b.halfWidth[0] - ax;
            const double ey = b.points[k + 1][1] / b.halfWidth[1] - ay;
            const double len2 = ex * ex + ey * ey;
            if (len2 > 0.0) {
                const double t = std::clamp(((px - ax) * ex + (py - ay) * ey) / len2, 0.0, 1.0);
                qx = ax + t * ex;
                qy = ay + t * ey;
            }
        } else if (n > 1) {
            continue;  // the last point is the end of the last segment
        }
        best2 = std::min(best2, (px - qx) * (px - qx) + (py - qy) * (py - qy));
    }
    const double d = std::sqrt(best2);
    if (b.tent) return std::max(0.0, 1.0 - d);
    return d <= 1.0 ? 1.0 : 0.0;
}

}  // namespace

double widgetOpacity(const Tf2Widget& w, double x, double y) {
    const double factor = std::visit(
        [&](const auto& s) -> double {
            using S = std::decay_t<decltype(s)>;
            if constexpr (std::is_same_v<S, Tf2Box>) return boxFactor(s, x, y);
            if constexpr (std::is_same_v<S, Tf2Triangle>) return triangleFactor(s, x, y);
            if constexpr (std::is_same_v<S, Tf2Ellipse>) return ellipseFactor(s, x, y);
            if constexpr (std::is_same_v<S, Tf2Band>) return bandFactor(s, x, y);
        },
        w.shape);
    return w.rgba[3] * factor;
}

TransferFunction2D rasterizeWidgets(const std::vector<Tf2Widget>& widgets, int width, int height,
                                    const std::array<double, 4>& domain) {
    TransferFunction2D tf;
    tf.width = width;
    tf.height = height;
    tf.x0 = domain[0];
    tf.x1 = domain[1];
    tf.y0 = domain[2];
    tf.y1 = domain[3];
    if (width < 2 || height < 2)
        UDVR_FAIL("2D transfer function: needs at least 2x2 points, got " << width << "x"
                                                                          << height);
    tf.rgba.assign(static_cast<std::size_t>(width) * height * 4, 0.f);
    // The first (point, widget) whose opacity is NaN (numbers too large or small to compute
    // with), so the error names the widget rather than the raster's colour check.
    const std::size_t none = std::numeric_limits<std::size_t>::max();
    std::atomic<std::size_t> firstNan{none};
    parallelForChunks(static_cast<std::size_t>(height), 8, [&](std::size_t jb, std::size_t je) {
        for (std::size_t j = jb; j < je; ++j) {
            const double y = tf.y0 + (tf.y1 - tf.y0) * static_cast<double>(j) / (height - 1);
            for (int i = 0; i < width; ++i) {
                const double x = tf.x0 + (tf.x1 - tf.x0) * i / (width - 1);
                double transmit = 1.0, sumAlpha = 0.0, sumColor[3] = {0.0, 0.0, 0.0};
                for (const Tf2Widget& w : widgets) {
                    const double a = widgetOpacity(w, x, y);
                    if (a <= 0.0) continue;
                    if (std::isnan(a)) {
                        const std::size_t at =
                            (j * static_cast<std::size_t>(width) + i) * widgets.size() +
                            static_cast<std::size_t>(&w - widgets.data());
                        std::size_t seen = firstNan.load();
                        while (at < seen && !firstNan.compare_exchange_weak(seen, at)) {
                        }
                        continue;
                    }
                    transmit *= 1.0 - a;
                    sumAlpha += a;
                    for (int ch = 0; ch < 3; ++ch) sumColor[ch] += a * w.rgba[ch];
                }
                float* p = tf.rgba.data() + (j * static_cast<std::size_t>(width) + i) * 4;
                for (int ch = 0; ch < 3; ++ch)
                    p[ch] = sumAlpha > 0.0
                                ? static_cast<float>(std::min(1.0, sumColor[ch] / sumAlpha))
                                : 0.f;
                p[3] = static_cast<float>(1.0 - transmit);
            }
        }
    });
    if (const std::size_t at = firstNan.load(); at != none) {
        const std::size_t point = at / widgets.size();
        UDVR_FAIL(
            "widget " << at % widgets.size() << " has no opacity (NaN) at x = "
                      << tf.x0 + (tf.x1 - tf.x0) * static_cast<double>(point % width) / (width - 1)
                      << ", y = "
                      << tf.y0 + (tf.y1 - tf.y0) * static_cast<double>(point / width) / (height - 1)
                      << ": its numbers are too large or too small to compute with");
    }
    tf.validate();
    return tf;
}

}  // namespace udvr
