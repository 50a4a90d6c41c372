#include "udvr/eval/tf2_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>

#include "udvr/eval/cairo_draw.h"
#include "udvr/eval/figure.h"
#include "udvr/util/check.h"

namespace udvr {

JointHistogram jointHistogram(std::span<const float> x, std::span<const float> y, int binsX,
                              int binsY, const std::array<double, 4>& domain) {
    UDVR_CHECK(x.size() == y.size() && binsX >= 1 && binsY >= 1);
    UDVR_CHECK(domain[0] < domain[1] && domain[2] < domain[3]);
    JointHistogram h;
    h.binsX = binsX;
    h.binsY = binsY;
    h.domain = domain;
    h.counts.assign(static_cast<std::size_t>(binsX) * binsY, 0.0);
    h.total = x.size();
    double xlo = std::numeric_limits<double>::infinity(), xhi = -xlo, ylo = xlo, yhi = -xlo;
    // Bin of v on n bins over [lo, hi]: -1 outside (NaN too), the last bin closed.
    const auto bin = [](double v, double lo, double hi, int n) {
        if (!(v >= lo && v <= hi)) return -1;
        return std::min(n - 1, static_cast<int>((v - lo) / (hi - lo) * n));
    };
    for (std::size_t k = 0; k < x.size(); ++k) {
        const double vx = x[k], vy = y[k];
        if (std::isfinite(vx) && std::isfinite(vy)) {
            xlo = std::min(xlo, vx), xhi = std::max(xhi, vx);
            ylo = std::min(ylo, vy), yhi = std::max(yhi, vy);
        }
        const int i = bin(vx, domain[0], domain[1], binsX);
        const int j = bin(vy, domain[2], domain[3], binsY);
        if (i < 0 || j < 0) {
            ++h.outside;
            continue;
        }
        h.counts[static_cast<std::size_t>(j) * binsX + i] += 1.0;
    }
    if (std::isfinite(xlo)) h.xMin = xlo, h.xMax = xhi, h.yMin = ylo, h.yMax = yhi;
    return h;
}

ImageRgba renderTf2Plot(const TransferFunction2D& tf, const JointHistogram* histogram,
                        const Tf2PlotOptions& options) {
    tf.validate();
    const int width = std::max(options.width, 160), height = std::max(options.height, 120);
    const double font = std::clamp(height / 40.0, 9.0, 13.0);
    // Plot area in figure pixels: room for y tick labels and label on the left, x below.
    const int left = static_cast<int>(std::lround(6.0 * font));
    const int right = width - static_cast<int>(std::lround(1.5 * font));
    const int top = static_cast<int>(std::lround((options.title.empty() ? 1.2 : 2.6) * font));
    const int bottom = height - static_cast<int>(std::lround(4.6 * font));  // ticks, label, note
    const int pw = right - left, ph = bottom - top;
    UDVR_CHECK(pw > 0 && ph > 0);

    double peak = 0.0;
    if (histogram != nullptr)
        for (double c : histogram->counts) peak = std::max(peak, c);
    double maxAlpha = 0.0;
    for (std::size_t k = 3; k < tf.rgba.size(); k += 4)
        maxAlpha = std::max(maxAlpha, static_cast<double>(tf.rgba[k]));

    // The plot area, pixel by pixel: x right, y up, each pixel sampled at its centre.
    ImageRgba area;
    area.width = pw;
    area.height = ph;
    area.rgba.assign(static_cast<std::size_t>(pw) * ph * 4, 1.f);
    for (int py = 0; py < ph; ++py) {
        const double y = tf.y1 - (py + 0.5) / ph * (tf.y1 - tf.y0);
        for (int px = 0; px < pw; ++px) {
            const double x = tf.x0 + (px + 0.5) / pw * (tf.x1 - tf.x0);
            double grey = 1.0;
            if (histogram != nullptr && peak > 0.0) {
                const auto& d = histogram->domain;
                const int i =
                    std::clamp(static_cast<int>((x - d[0]) / (d[1] - d[0]) * histogram->binsX), 0,
                               histogram->binsX - 1);
                const int j =
                    std::clamp(static_cast<int>((y - d[2]) / (d[3] - d[2]) * histogram->binsY), 0,
                               histogram->binsY - 1);
                const double c = histogram->count(i, j);
                const double s = options.logScale ? std::log1p(c) / std::log1p(peak) : c / peak;
                grey = 1.0 - 0.92 * s;
            }
            const auto co = tf.colorOpacityAt(x, y);
            const double w = maxAlpha > 0.0 ? 0.85 * co[3] / maxAlpha : 0.0;
            float* p = area.pixel(px, py);
            for (int ch = 0; ch < 3; ++ch)
                p[ch] = static_cast<float>((1.0 - w) * grey + w * co[ch]);
        }
    }

    detail::SurfacePtr surface = detail::makeSurface(CAIRO_FORMAT_ARGB32, width, height);
    detail::ContextPtr crp(cairo_create(surface.get()));
    cairo_t* cr = crp.get();
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_paint(cr);
    detail::pasteImage(surface.get(), area, left, top);
    detail::drawAxes(cr, {static_cast<double>(left), static_cast<double>(top),
                          static_cast<double>(pw), static_cast<double>(ph), tf.x0, tf.x1, tf.y0,
                          tf.y1, options.xLabel, options.yLabel, font});
    if (!options.title.empty())
        detail::textCentred(cr, options.title, width / 2.0, 1.7 * font, width - 2.0 * font,
                            font * 1.1, true);
    // What the shades mean, on its own line under the axis label (not over the data).
    char note[128];
    std::snprintf(note, sizeof note, "max alpha %.3g%s", maxAlpha,
                  histogram == nullptr ? ""
                  : options.logScale   ? ", grey: log(1 + count)"
                                       : ", grey: count");
    detail::textAt(cr, note, right, height - 0.5 * font, font * 0.9, false, 1.0);
    crp.reset();
    return detail::surfaceToImage(surface.get());
}

}  // namespace udvr
