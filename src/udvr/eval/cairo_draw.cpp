// Cairo helpers shared by the figure renderers (figure.cpp, tf2_plot.cpp, probe_plot.cpp,
// histogram_plot.cpp).
#include "udvr/eval/cairo_draw.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numbers>
#include <vector>

#include "udvr/eval/figure.h"
#include "udvr/util/check.h"

namespace udvr::detail {
namespace {

const char* const kFont = "DejaVu Sans";

std::uint8_t toByte(float v) {
    if (!(v > 0.f)) return 0;  // also NaN
    if (v >= 1.f) return 255;
    return static_cast<std::uint8_t>(std::lround(v * 255.f));
}

}  // namespace

SurfacePtr makeSurface(cairo_format_t format, int width, int height) {
    SurfacePtr s(cairo_image_surface_create(format, width, height));
    if (cairo_surface_status(s.get()) != CAIRO_STATUS_SUCCESS)
        UDVR_FAIL("cannot create a " << width << "x" << height << " figure surface: "
                                     << cairo_status_to_string(cairo_surface_status(s.get())));
    return s;
}

void pasteImage(cairo_surface_t* surface, const ImageRgba& image, int x0, int y0) {
    cairo_surface_flush(surface);
    unsigned char* data = cairo_image_surface_get_data(surface);
    const int stride = cairo_image_surface_get_stride(surface);
    const int sw = cairo_image_surface_get_width(surface);
    const int sh = cairo_image_surface_get_height(surface);
    for (int y = 0; y < image.height; ++y) {
        const int py = y0 + y;
        if (py < 0 || py >= sh) continue;
        auto* row =
            reinterpret_cast<std::uint32_t*>(data + static_cast<std::ptrdiff_t>(py) * stride);
        for (int x = 0; x < image.width; ++x) {
            const int px = x0 + x;
            if (px < 0 || px >= sw) continue;
            const float* p = image.pixel(x, y);
            row[px] = 0xFF000000u | (std::uint32_t{toByte(p[0])} << 16) |
                      (std::uint32_t{toByte(p[1])} << 8) | std::uint32_t{toByte(p[2])};
        }
    }
    cairo_surface_mark_dirty(surface);
}

ImageRgba surfaceToImage(cairo_surface_t* surface) {
    cairo_surface_flush(surface);
    ImageRgba out;
    out.width = cairo_image_surface_get_width(surface);
    out.height = cairo_image_surface_get_height(surface);
    out.rgba.resize(static_cast<std::size_t>(out.width) * out.height * 4);
    const unsigned char* data = cairo_image_surface_get_data(surface);
    const int stride = cairo_image_surface_get_stride(surface);
    for (int y = 0; y < out.height; ++y) {
        const auto* row =
            reinterpret_cast<const std::uint32_t*>(data + static_cast<std::ptrdiff_t>(y) * stride);
        for (int x = 0; x < out.width; ++x) {
            const std::uint32_t v = row[x];
            const float a = static_cast<float>((v >> 24) & 0xFF);
            float* p = out.pixel(x, y);
            for (int c = 0; c < 3; ++c) {
                const float byte = static_cast<float>((v >> (16 - 8 * c)) & 0xFF);
                // ARGB32 is premultiplied; figures are opaque, but un-premultiply to be safe.
                p[c] = a > 0.f ? std::min(1.f, byte / a) : 0.f;
            }
            p[3] = 1.f;
        }
    }
    return out;
}

void setFont(cairo_t* cr, double size, bool bold) {
    cairo_select_font_face(cr, kFont, CAIRO_FONT_SLANT_NORMAL,
                           bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_font_size(cr, size);
}

void textCentred(cairo_t* cr, const std::string& text, double cx, double y, double maxWidth,
                 double size, bool bold) {
    setFont(cr, size, bold);
    cairo_text_extents_t ext;
    cairo_text_extents(cr, text.c_str(), &ext);
    if (ext.x_advance > maxWidth && ext.x_advance > 0) {
        setFont(cr, size * maxWidth / ext.x_advance, bold);
        cairo_text_extents(cr, text.c_str(), &ext);
    }
    cairo_move_to(cr, cx - ext.x_advance / 2, y);
    cairo_show_text(cr, text.c_str());
}

void textAt(cairo_t* cr, const std::string& text, double x, double y, double size, bool bold,
            double alignX) {
    setFont(cr, size, bold);
    cairo_text_extents_t ext;
    cairo_text_extents(cr, text.c_str(), &ext);
    cairo_move_to(cr, x - alignX * ext.x_advance, y);
    cairo_show_text(cr, text.c_str());
}

std::string formatTick(double v, double step) {
    char buf[64];
    const int decimals =
        step >= 1.0 ? 0 : std::min(8, static_cast<int>(std::ceil(-std::log10(step) - 1e-9)));
    std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
    return buf;
}

void drawAxes(cairo_t* cr, const PlotAxes& a) {
    const double bottom = a.top + a.height;
    const auto px = [&](double x) { return a.left + (x - a.x0) / (a.x1 - a.x0) * a.width; };
    const auto py = [&](double y) { return bottom - (y - a.y0) / (a.y1 - a.y0) * a.height; };
    const double font = a.font;
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_set_line_width(cr, 1.0);
    cairo_rectangle(cr, a.left + 0.5, a.top + 0.5, a.width - 1.0, a.height - 1.0);
    cairo_stroke(cr);
    const std::vector<double> xTicks =
        niceTicks(a.x0, a.x1, std::max(2, static_cast<int>(a.width / 70)));
    const std::vector<double> yTicks =
        niceTicks(a.y0, a.y1, std::max(2, static_cast<int>(a.height / 50)));
    const double xStep = xTicks.size() >= 2 ? xTicks[1] - xTicks[0] : a.x1 - a.x0;
    const double yStep = yTicks.size() >= 2 ? yTicks[1] - yTicks[0] : a.y1 - a.y0;
    for (double t : xTicks) {
        const double x = std::round(px(t)) + 0.5;
        cairo_move_to(cr, x, bottom);
        cairo_line_to(cr, x, bottom + 0.4 * font);
        cairo_stroke(cr);
        textAt(cr, formatTick(t, xStep), x, bottom + 1.4 * font, font, false, 0.5);
    }
    for (double t : yTicks) {
        const double y = std::round(py(t)) + 0.5;
        cairo_move_to(cr, a.left - 0.4 * font, y);
        cairo_line_to(cr, a.left, y);
        cairo_stroke(cr);
        textAt(cr, formatTick(t, yStep), a.left - 0.6 * font, y + 0.35 * font, font, false, 1.0);
    }
    textAt(cr, a.xLabel, a.left + a.width / 2.0, bottom + 2.7 * font, font, false, 0.5);
    cairo_save(cr);
    cairo_translate(cr, 1.3 * font, a.top + a.height / 2.0);
    cairo_rotate(cr, -std::numbers::pi / 2);
    textAt(cr, a.yLabel, 0, 0, font, false, 0.5);
    cairo_restore(cr);
}

void fillTfColour(cairo_t* cr, const TransferFunction1D& tf, double x0, double x1, double left,
                  double top, int columns, double height) {
    for (int c = 0; c < columns; ++c) {
        const auto rgb = tf.colorAt(x0 + (c + 0.5) / columns * (x1 - x0));
        cairo_set_source_rgb(cr, rgb[0], rgb[1], rgb[2]);
        cairo_rectangle(cr, left + c, top, 1.0, height);
        cairo_fill(cr);
    }
}

void strokeColumns(cairo_t* cr, double left, int columns, const std::function<double(int)>& y,
                   double lineWidth) {
    if (columns < 1) return;
    cairo_set_line_width(cr, lineWidth);
    cairo_move_to(cr, left + 0.5, y(0));
    for (int c = 1; c < columns; ++c) cairo_line_to(cr, left + c + 0.5, y(c));
    cairo_stroke(cr);
}

}  // namespace udvr::detail
