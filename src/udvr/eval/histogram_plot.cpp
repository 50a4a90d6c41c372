#include "udvr/eval/histogram_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "udvr/eval/cairo_draw.h"
#include "udvr/util/check.h"

namespace udvr {

ImageRgba renderHistogramPlot(const Histogram& h, const TransferFunction1D* tf,
                              const HistogramPlotOptions& options) {
    UDVR_CHECK(!h.counts.empty() && h.lo < h.hi);
    const int width = std::max(options.width, 200), height = std::max(options.height, 150);
    const double font = std::clamp(height / 32.0, 9.0, 13.0);
    const double left = std::round(6.5 * font), right = width - std::round(1.5 * font);
    const double top = std::round((options.title.empty() ? 1.2 : 2.6) * font);
    const double bottom = height - std::round(4.6 * font);
    const double pw = right - left, ph = bottom - top;
    UDVR_CHECK(pw > 0 && ph > 0);

    const auto height01 = [&](double count) {
        return options.logScale ? std::log10(1.0 + count) : count;
    };
    double peak = 0.0;
    for (auto c : h.counts) peak = std::max(peak, height01(static_cast<double>(c)));
    const double yMax = peak > 0.0 ? peak * 1.05 : 1.0;

    detail::SurfacePtr surface = detail::makeSurface(CAIRO_FORMAT_ARGB32, width, height);
    detail::ContextPtr crp(cairo_create(surface.get()));
    cairo_t* cr = crp.get();
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_paint(cr);

    const double stripHeight = tf != nullptr ? std::round(0.8 * font) : 0.0;
    const auto px = [&](double x) { return left + (x - h.lo) / (h.hi - h.lo) * pw; };
    const int cols = static_cast<int>(pw);
    if (tf != nullptr)  // TF colour along the top of the plot, one column per pixel
        detail::fillTfColour(cr, *tf, h.lo, h.hi, left, top, cols, stripHeight);
    const double barHeight = ph - stripHeight;  // bars stay below the colour strip
    const std::size_t bins = h.counts.size();
    const double binWidth = (h.hi - h.lo) / static_cast<double>(bins);
    cairo_set_source_rgb(cr, 0.45, 0.5, 0.6);
    for (std::size_t b = 0; b < bins; ++b) {
        const double v = height01(static_cast<double>(h.counts[b]));
        if (!(v > 0.0)) continue;
        const double x0 = px(h.lo + binWidth * static_cast<double>(b));
        const double x1 = px(h.lo + binWidth * static_cast<double>(b + 1));
        const double bar = barHeight * v / yMax;
        cairo_rectangle(cr, x0, bottom - bar, std::max(x1 - x0, 1.0), bar);
    }
    cairo_fill(cr);

    double maxAlpha = 0.0;
    if (tf != nullptr) {
        for (double a : tf->opacity) maxAlpha = std::max(maxAlpha, a);
        if (maxAlpha > 0.0) {
            cairo_set_source_rgb(cr, 0.0, 0.0, 0.0);
            detail::strokeColumns(
                cr, left, cols,
                [&](int c) {
                    const double x = h.lo + (c + 0.5) / cols * (h.hi - h.lo);
                    return bottom - barHeight * 0.95 * tf->opacityAt(x) / maxAlpha;
                },
                1.5);
        }
    }
    detail::drawAxes(cr, {left, top, pw, ph, h.lo, h.hi, 0.0, yMax, options.xLabel,
                          options.logScale ? "log10(1 + count)" : "count", font});
    if (!options.title.empty())
        detail::textCentred(cr, options.title, width / 2.0, 1.7 * font, width - 2.0 * font,
                            font * 1.1, true);
    char note[160];
    std::snprintf(note, sizeof note, "%llu values below, %llu above the range%s",
                  static_cast<unsigned long long>(h.below),
                  static_cast<unsigned long long>(h.above),
                  tf != nullptr ? "; black: TF opacity, top: TF colour" : "");
    std::string text = note;
    if (tf != nullptr) {
        char alpha[48];
        std::snprintf(alpha, sizeof alpha, " (max alpha %.3g)", maxAlpha);
        text += alpha;
    }
    detail::textAt(cr, text, right, height - 0.5 * font, font * 0.9, false, 1.0);
    crp.reset();
    return detail::surfaceToImage(surface.get());
}

}  // namespace udvr
