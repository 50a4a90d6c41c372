#include "udvr/eval/figure.h"

#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <numbers>

#include "udvr/eval/cairo_draw.h"
#include "udvr/eval/image_metrics.h"
#include "udvr/util/atomic_file.h"
#include "udvr/util/check.h"

namespace udvr {
namespace {

using detail::ContextPtr;
using detail::formatTick;
using detail::makeSurface;
using detail::pasteImage;
using detail::setFont;
using detail::SurfacePtr;
using detail::surfaceToImage;
using detail::textAt;
using detail::textCentred;

// Panel geometry, pixels.
constexpr int kMargin = 12;
constexpr int kGap = 10;
constexpr int kTitleBand = 30;
constexpr int kLineHeight = 16;
constexpr double kCaptionFont = 12.5;
constexpr double kTitleFont = 16.0;

}  // namespace

PanelLayout panelLayout(const FigurePanel& panel) {
    UDVR_CHECK(panel.columns >= 1);
    PanelLayout l;
    std::size_t lines = 0;
    for (const FigureCell& c : panel.cells) {
        l.cellWidth = std::max(l.cellWidth, c.image.width);
        l.cellHeight = std::max(l.cellHeight, c.image.height);
        lines = std::max(lines, c.caption.size());
    }
    l.cellWidth = std::max(l.cellWidth, 1);
    l.cellHeight = std::max(l.cellHeight, 1);
    l.captionHeight = lines > 0 ? static_cast<int>(lines) * kLineHeight + 8 : 0;
    const int n = static_cast<int>(panel.cells.size());
    const int cols = std::max(1, std::min(panel.columns, n));
    const int rows = n == 0 ? 0 : (n + cols - 1) / cols;
    const int top = kMargin + (panel.title.empty() ? 0 : kTitleBand);
    l.rowHeight.assign(static_cast<std::size_t>(rows), 1);
    for (int i = 0; i < n; ++i) {
        int& h = l.rowHeight[static_cast<std::size_t>(i / cols)];
        h = std::max(h, panel.cells[static_cast<std::size_t>(i)].image.height);
    }
    l.width = 2 * kMargin + cols * l.cellWidth + (cols - 1) * kGap;
    int y = top;
    std::vector<int> rowTop;
    for (int h : l.rowHeight) {
        rowTop.push_back(y);
        y += h + l.captionHeight + kGap;
    }
    l.height = y - (rows > 0 ? kGap : 0) + kMargin;
    for (int i = 0; i < n; ++i) {
        const int col = i % cols;
        const int x = kMargin + col * (l.cellWidth + kGap) +
                      (l.cellWidth - panel.cells[static_cast<std::size_t>(i)].image.width) / 2;
        l.imageOrigin.push_back({x, rowTop[static_cast<std::size_t>(i / cols)]});
    }
    return l;
}

ImageRgba renderPanel(const FigurePanel& panel) {
    const PanelLayout l = panelLayout(panel);
    SurfacePtr surface = makeSurface(CAIRO_FORMAT_ARGB32, l.width, l.height);
    ContextPtr cr(cairo_create(surface.get()));
    cairo_set_source_rgb(cr.get(), 1, 1, 1);
    cairo_paint(cr.get());
    cairo_set_source_rgb(cr.get(), 0, 0, 0);
    if (!panel.title.empty())
        textCentred(cr.get(), panel.title, l.width / 2.0, kMargin + kTitleFont,
                    l.width - 2.0 * kMargin, kTitleFont, true);
    const int cols =
        std::max(1, std::min<int>(panel.columns, static_cast<int>(panel.cells.size())));
    for (std::size_t i = 0; i < panel.cells.size(); ++i) {
        const FigureCell& cell = panel.cells[i];
        const int col = static_cast<int>(i) % cols;
        const double cx = kMargin + col * (l.cellWidth + kGap) + l.cellWidth / 2.0;
        double y =
            l.imageOrigin[i][1] + l.rowHeight[i / static_cast<std::size_t>(cols)] + kLineHeight;
        for (std::size_t k = 0; k < cell.caption.size(); ++k) {
            textCentred(cr.get(), cell.caption[k], cx, y, l.cellWidth + kGap - 2.0, kCaptionFont,
                        k == 0);
            y += kLineHeight;
        }
    }
    cr.reset();
    for (std::size_t i = 0; i < panel.cells.size(); ++i)
        pasteImage(surface.get(), panel.cells[i].image, l.imageOrigin[i][0], l.imageOrigin[i][1]);
    return surfaceToImage(surface.get());
}

std::vector<double> niceTicks(double lo, double hi, int maxTicks) {
    UDVR_CHECK(std::isfinite(lo) && std::isfinite(hi) && maxTicks >= 1);
    if (hi < lo) std::swap(lo, hi);
    double span = hi - lo;
    if (span <= 0) span = lo != 0 ? std::abs(lo) : 1.0;
    const double raw = span / maxTicks;
    const double mag = std::pow(10.0, std::floor(std::log10(raw)));
    double step = 10 * mag;
    for (double m : {1.0, 2.0, 5.0, 10.0})
        if (m * mag >= raw) {
            step = m * mag;
            break;
        }
    std::vector<double> ticks;
    const double first = std::ceil(lo / step - 1e-9) * step;
    for (double t = first; t <= hi + 1e-9 * span; t += step)
        ticks.push_back(std::abs(t) < 1e-12 * step ? 0.0 : t);
    return ticks;
}

ImageRgba renderLinePlots(const std::vector<PlotAxes>& plots, int width, int height) {
    UDVR_CHECK(!plots.empty() && width > 0 && height > 0);
    // Shared y range over every finite value.
    double ylo = std::numeric_limits<double>::infinity(), yhi = -ylo;
    for (const PlotAxes& p : plots)
        for (const PlotSeries& s : p.series) {
            UDVR_CHECK(s.x.size() == s.y.size());
            for (double v : s.y)
                if (std::isfinite(v)) ylo = std::min(ylo, v), yhi = std::max(yhi, v);
        }
    if (!std::isfinite(ylo)) ylo = 0, yhi = 1;
    if (yhi - ylo <= 0) {
        const double pad = ylo != 0 ? 0.1 * std::abs(ylo) : 1.0;
        ylo -= pad, yhi += pad;
    }
    {
        const double pad = 0.08 * (yhi - ylo);
        ylo -= pad, yhi += pad;
    }
    const std::vector<double> yTicks = niceTicks(ylo, yhi, 6);
    const double yStep = yTicks.size() >= 2 ? yTicks[1] - yTicks[0] : (yhi - ylo);

    SurfacePtr surface = makeSurface(CAIRO_FORMAT_ARGB32, width, height);
    ContextPtr crp(cairo_create(surface.get()));
    cairo_t* cr = crp.get();
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_paint(cr);

    const double font = std::clamp(height / 32.0, 9.0, 14.0);
    // Width of the legend column: the longest label plus its line sample.
    double legendW = 0;
    setFont(cr, font, false);
    for (const PlotSeries& s : plots.front().series) {
        cairo_text_extents_t ext;
        cairo_text_extents(cr, s.label.c_str(), &ext);
        legendW = std::max(legendW, ext.x_advance + 3.4 * font);
    }
    const double plotsWidth = std::max(0.5 * width, width - legendW);
    const double plotW = plotsWidth / static_cast<double>(plots.size());
    for (std::size_t pIndex = 0; pIndex < plots.size(); ++pIndex) {
        const PlotAxes& p = plots[pIndex];
        const double pi = static_cast<double>(pIndex);
        const double left = pi * plotW + 5.5 * font, right = (pi + 1) * plotW - font;
        const double top = 2.6 * font, bottom = height - 3.6 * font;
        if (right - left < 10 || bottom - top < 10) continue;
        // x range over the union of x values (log-transformed when asked).
        auto tx = [&](double x) { return p.logX ? std::log(std::max(x, 1e-300)) : x; };
        std::vector<double> xs;
        for (const PlotSeries& s : p.series) xs.insert(xs.end(), s.x.begin(), s.x.end());
        std::sort(xs.begin(), xs.end());
        xs.erase(std::unique(xs.begin(), xs.end()), xs.end());
        double xlo = xs.empty() ? 0.0 : tx(xs.front()), xhi = xs.empty() ? 1.0 : tx(xs.back());
        if (xhi - xlo <= 0) xlo -= 1, xhi += 1;
        const double xpad = 0.06 * (xhi - xlo);
        xlo -= xpad, xhi += xpad;
        auto px = [&](double x) { return left + (tx(x) - xlo) / (xhi - xlo) * (right - left); };
        auto py = [&](double y) { return bottom - (y - ylo) / (yhi - ylo) * (bottom - top); };

        // Grid lines and y tick labels.
        cairo_set_line_width(cr, 1.0);
        for (double t : yTicks) {
            cairo_set_source_rgb(cr, 0.88, 0.88, 0.88);
            cairo_move_to(cr, left, std::round(py(t)) + 0.5);
            cairo_line_to(cr, right, std::round(py(t)) + 0.5);
            cairo_stroke(cr);
            cairo_set_source_rgb(cr, 0, 0, 0);
            textAt(cr, formatTick(t, yStep), left - 0.4 * font, py(t) + 0.35 * font, font, false,
                   1.0);
        }
        for (double x : xs) {
            cairo_set_source_rgb(cr, 0, 0, 0);
            char buf[32];
            std::snprintf(buf, sizeof buf, "%g", x);
            textAt(cr, buf, px(x), bottom + 1.3 * font, font, false, 0.5);
            cairo_move_to(cr, std::round(px(x)) + 0.5, bottom);
            cairo_line_to(cr, std::round(px(x)) + 0.5, bottom + 0.3 * font);
            cairo_stroke(cr);
        }
        // Frame.
        cairo_set_source_rgb(cr, 0, 0, 0);
        cairo_rectangle(cr, std::round(left) + 0.5, std::round(top) + 0.5, std::round(right - left),
                        std::round(bottom - top));
        cairo_stroke(cr);
        // Labels.
        textAt(cr, p.title, (left + right) / 2, 1.6 * font, font * 1.1, true, 0.5);
        textAt(cr, p.xLabel, (left + right) / 2, height - 0.8 * font, font, false, 0.5);
        cairo_save(cr);
        cairo_translate(cr, pi * plotW + 1.3 * font, (top + bottom) / 2);
        cairo_rotate(cr, -std::numbers::pi / 2);
        textAt(cr, p.yLabel, 0, 0, font, false, 0.5);
        cairo_restore(cr);

        // Series, clipped to the frame.
        cairo_save(cr);
        cairo_rectangle(cr, left, top, right - left, bottom - top);
        cairo_clip(cr);
        for (const PlotSeries& s : p.series) {
            cairo_set_source_rgb(cr, s.color[0], s.color[1], s.color[2]);
            cairo_set_line_width(cr, 2.0);
            if (s.dashed) {
                const double dash[] = {6.0, 4.0};
                cairo_set_dash(cr, dash, 2, 0);
            } else {
                cairo_set_dash(cr, nullptr, 0, 0);
            }
            bool penDown = false;
            for (std::size_t i = 0; i < s.x.size(); ++i) {
                if (!std::isfinite(s.y[i])) {
                    penDown = false;
                    continue;
                }
                if (penDown)
                    cairo_line_to(cr, px(s.x[i]), py(s.y[i]));
                else
                    cairo_move_to(cr, px(s.x[i]), py(s.y[i]));
                penDown = true;
            }
            cairo_stroke(cr);
            cairo_set_dash(cr, nullptr, 0, 0);
            for (std::size_t i = 0; i < s.x.size(); ++i) {
                if (!std::isfinite(s.y[i])) continue;
                cairo_arc(cr, px(s.x[i]), py(s.y[i]), 3.2, 0, 2 * std::numbers::pi);
                cairo_fill(cr);
            }
        }
        cairo_restore(cr);
    }

    // One legend for all plots (they share their series), in the column right of them.
    if (!plots.front().series.empty()) {
        const auto& series = plots.front().series;
        const double lineW = 2.2 * font;
        const double boxH = static_cast<double>(series.size()) * 1.3 * font + 0.6 * font;
        const double bx = plotsWidth + 0.2 * font;
        const double by = std::max(2.6 * font, (height - boxH) / 2);
        for (std::size_t i = 0; i < series.size(); ++i) {
            const PlotSeries& s = series[i];
            const double ly = by + 0.3 * font + (static_cast<double>(i) + 0.5) * 1.3 * font;
            cairo_set_source_rgb(cr, s.color[0], s.color[1], s.color[2]);
            cairo_set_line_width(cr, 2.0);
            if (s.dashed) {
                const double dash[] = {6.0, 4.0};
                cairo_set_dash(cr, dash, 2, 0);
            }
            cairo_move_to(cr, bx, ly);
            cairo_line_to(cr, bx + lineW, ly);
            cairo_stroke(cr);
            cairo_set_dash(cr, nullptr, 0, 0);
            cairo_set_source_rgb(cr, 0, 0, 0);
            textAt(cr, s.label, bx + lineW + 0.6 * font, ly + 0.35 * font, font, false);
        }
    }
    crp.reset();
    return surfaceToImage(surface.get());
}

ImageRgba downsampleImage(const ImageRgba& image, int factor) {
    UDVR_CHECK(factor >= 1);
    if (factor == 1) return image;
    ImageRgba out;
    out.width = (image.width + factor - 1) / factor;
    out.height = (image.height + factor - 1) / factor;
    out.rgba.assign(static_cast<std::size_t>(out.width) * out.height * 4, 0.f);
    for (int y = 0; y < out.height; ++y)
        for (int x = 0; x < out.width; ++x) {
            double sum[4] = {0, 0, 0, 0};
            int n = 0;
            for (int yy = y * factor; yy < std::min(image.height, (y + 1) * factor); ++yy)
                for (int xx = x * factor; xx < std::min(image.width, (x + 1) * factor); ++xx) {
                    const float* p = image.pixel(xx, yy);
                    for (int c = 0; c < 4; ++c) sum[c] += p[c];
                    ++n;
                }
            float* o = out.pixel(x, y);
            for (int c = 0; c < 4; ++c) o[c] = static_cast<float>(sum[c] / n);
        }
    return out;
}

ImageRgba renderTransferFunction(const TransferFunction1D& tf, int width, int height) {
    UDVR_CHECK(width > 0 && height > 0);
    SurfacePtr surface = makeSurface(CAIRO_FORMAT_ARGB32, width, height);
    ContextPtr crp(cairo_create(surface.get()));
    cairo_t* cr = crp.get();
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_paint(cr);
    auto [lo, hi] = tf.domain();
    if (!(hi > lo)) hi = lo + 1.0;
    const double font = std::clamp(height / 18.0, 8.0, 12.0);
    const double left = 0.06 * width, right = width - 0.06 * width;
    const double barTop = height - 2.6 * font - 0.12 * height, barBottom = height - 2.6 * font;
    const double top = 0.08 * height, bottom = barTop - 0.04 * height;
    double maxAlpha = 0;
    for (double a : tf.opacity) maxAlpha = std::max(maxAlpha, a);
    if (maxAlpha <= 0) maxAlpha = 1;
    // Colour bar: one column per pixel.
    for (int px = static_cast<int>(left); px < static_cast<int>(right); ++px) {
        const double x = lo + (px + 0.5 - left) / (right - left) * (hi - lo);
        const auto c = tf.colorAt(x);
        cairo_set_source_rgb(cr, c[0], c[1], c[2]);
        cairo_rectangle(cr, px, barTop, 1, barBottom - barTop);
        cairo_fill(cr);
    }
    // Opacity, scaled to its largest value (printed).
    cairo_set_source_rgb(cr, 0.93, 0.93, 0.93);
    cairo_rectangle(cr, left, top, right - left, bottom - top);
    cairo_fill(cr);
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_set_line_width(cr, 1.5);
    const int steps = std::max(2, static_cast<int>(right - left) * 2);
    for (int i = 0; i <= steps; ++i) {
        const double x = lo + (hi - lo) * i / steps;
        const double px = left + (right - left) * i / steps;
        const double py = bottom - tf.opacityAt(x) / maxAlpha * (bottom - top);
        if (i == 0)
            cairo_move_to(cr, px, py);
        else
            cairo_line_to(cr, px, py);
    }
    cairo_stroke(cr);
    char buf[64];
    std::snprintf(buf, sizeof buf, "%g", lo);
    textAt(cr, buf, left, height - 0.9 * font, font, false, 0.0);
    std::snprintf(buf, sizeof buf, "%g", hi);
    textAt(cr, buf, right, height - 0.9 * font, font, false, 1.0);
    std::snprintf(buf, sizeof buf, "max alpha %.3g", maxAlpha);
    textAt(cr, buf, right - 0.3 * font, top + 1.2 * font, font, false, 1.0);
    crp.reset();
    return surfaceToImage(surface.get());
}

void writeFigurePng(const std::filesystem::path& path, const ImageRgba& image) {
    UDVR_CHECK(image.width > 0 && image.height > 0 &&
               image.rgba.size() == static_cast<std::size_t>(image.width) * image.height * 4);
    SurfacePtr surface = makeSurface(CAIRO_FORMAT_RGB24, image.width, image.height);
    pasteImage(surface.get(), image, 0, 0);
    std::string bytes;
    auto append = [](void* closure, const unsigned char* data, unsigned int length) {
        static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(data), length);
        return CAIRO_STATUS_SUCCESS;
    };
    const cairo_status_t st = cairo_surface_write_to_png_stream(surface.get(), append, &bytes);
    if (st != CAIRO_STATUS_SUCCESS)
        UDVR_FAIL("cannot encode PNG " << path.string() << ": " << cairo_status_to_string(st));
    writeFileAtomically(path, bytes);
}

ImageRgba withDifferenceScale(const ImageRgba& image, double maxValue, const std::string& label) {
    const int w = image.width + kColourScaleWidth, h = std::max(image.height, 64);
    SurfacePtr surface = makeSurface(CAIRO_FORMAT_ARGB32, w, h);
    ContextPtr cr(cairo_create(surface.get()));
    cairo_set_source_rgb(cr.get(), 1, 1, 1);
    cairo_paint(cr.get());
    pasteImage(surface.get(), image, 0, 0);
    cairo_surface_flush(surface.get());
    // The bar: 12 px wide, from 18 px below the top (room for the label) to 8 px above the
    // bottom; each row the map's colour at its height.
    const double font = 10.0, x0 = image.width + 8.0, barW = 12.0;
    const double top = 18.0, bottom = h - 8.0;
    for (int y = static_cast<int>(top); y < static_cast<int>(bottom); ++y) {
        const double t = (bottom - (y + 0.5)) / (bottom - top);
        float rgb[3];
        differenceColor(t, rgb);
        cairo_set_source_rgb(cr.get(), rgb[0], rgb[1], rgb[2]);
        cairo_rectangle(cr.get(), x0, y, barW, 1.0);
        cairo_fill(cr.get());
    }
    cairo_set_source_rgb(cr.get(), 0, 0, 0);
    cairo_set_line_width(cr.get(), 1.0);
    cairo_rectangle(cr.get(), x0 - 0.5, top - 0.5, barW + 1.0, bottom - top + 1.0);
    cairo_stroke(cr.get());
    textAt(cr.get(), label, image.width + 4.0, 12.0, font, false);
    const double step = maxValue > 0.0 ? maxValue / 4.0 : 1.0;
    for (int k = 0; k <= 4; ++k) {
        const double v = k * step, y = bottom - (bottom - top) * k / 4.0;
        cairo_move_to(cr.get(), x0 + barW, y);
        cairo_line_to(cr.get(), x0 + barW + 3.0, y);
        cairo_stroke(cr.get());
        textAt(cr.get(), formatTick(maxValue > 0.0 ? v : 0.0, step), x0 + barW + 5.0,
               y + font / 2.5, font, false);
    }
    return surfaceToImage(surface.get());
}

}  // namespace udvr
