#include "udvr/eval/probe_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "udvr/eval/cairo_draw.h"
#include "udvr/util/check.h"

namespace udvr {
namespace {

// Piecewise-linear interpolation of the sampled CDF at x.
double cdfAt(const ProbeDistribution& d, double x) {
    if (d.cdfX.empty()) return 0.0;
    if (x <= d.cdfX.front()) return d.cdfY.front();
    if (x >= d.cdfX.back()) return d.cdfY.back();
    const auto it = std::upper_bound(d.cdfX.begin(), d.cdfX.end(), x);
    const std::size_t i = static_cast<std::size_t>(it - d.cdfX.begin());
    const double t = (x - d.cdfX[i - 1]) / (d.cdfX[i] - d.cdfX[i - 1]);
    return d.cdfY[i - 1] + t * (d.cdfY[i] - d.cdfY[i - 1]);
}

}  // namespace

ImageRgba renderProbePlot(const ProbeResult& r, const TransferFunction1D& tf, int width,
                          int height) {
    const ProbeDistribution& d = r.distribution;
    UDVR_CHECK(d.hi > d.lo);
    width = std::max(width, 200);
    height = std::max(height, 150);
    const double font = std::clamp(height / 36.0, 7.0, 12.0);
    const double left = std::round(6.0 * font), right = width - std::round(1.5 * font);
    const double pw = right - left;
    // Two panels sharing x: the distribution (upper 60 %) and the TF (lower), each with ticks,
    // tick labels and axis labels below it.
    const double pdfTop = std::round(1.2 * font);
    const double tfBottom = height - std::round(3.4 * font);
    const double gap = std::round(3.6 * font);
    const double pdfHeight = std::round(0.62 * (tfBottom - pdfTop - gap));
    const double tfTop = pdfTop + pdfHeight + gap, tfHeight = tfBottom - tfTop;
    UDVR_CHECK(pw > 0 && pdfHeight > 0 && tfHeight > 0);
    const int cols = static_cast<int>(pw);
    auto xOf = [&](double col) { return d.lo + (d.hi - d.lo) * col / cols; };

    detail::SurfacePtr surface = detail::makeSurface(CAIRO_FORMAT_ARGB32, width, height);
    detail::ContextPtr crp(cairo_create(surface.get()));
    cairo_t* cr = crp.get();
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_paint(cr);

    // Continuous density per column = Δcdf / Δx, normalised to its peak (blue).
    std::vector<double> dens(static_cast<std::size_t>(cols), 0.0);
    double peak = 0.0;
    if (d.continuousMass > 0)
        for (int c = 0; c < cols; ++c) {
            const double x0 = xOf(c), x1 = xOf(c + 1);
            dens[c] = (cdfAt(d, x1) - cdfAt(d, x0)) / (x1 - x0);
            peak = std::max(peak, dens[c]);
        }
    const double pdfBottom = pdfTop + pdfHeight;
    const double scale = pdfHeight / 1.05;  // peak at 1 on a 0..1.05 axis
    if (peak > 0.0) {
        cairo_set_source_rgb(cr, 0.55, 0.7, 0.95);
        for (int c = 0; c < cols; ++c) {
            const double bar = scale * dens[c] / peak;
            cairo_rectangle(cr, left + c, pdfBottom - bar, 1.0, bar);
        }
        cairo_fill(cr);
        cairo_set_source_rgb(cr, 0.1, 0.25, 0.7);
        detail::strokeColumns(
            cr, left, cols, [&](int c) { return pdfBottom - scale * dens[c] / peak; }, 1.2);
    }
    // Point masses as red spikes, the largest at full height.
    double atomPeak = 0.0;
    for (double m : d.atomMass) atomPeak = std::max(atomPeak, m);
    cairo_set_source_rgb(cr, 0.85, 0.1, 0.1);
    for (std::size_t i = 0; i < d.atoms.size() && atomPeak > 0.0; ++i) {
        const double x = left + (d.atoms[i] - d.lo) / (d.hi - d.lo) * pw;
        const double bar = scale * d.atomMass[i] / atomPeak;
        cairo_rectangle(cr, x - 1.5, pdfBottom - bar, 3.0, bar);
    }
    cairo_fill(cr);
    const bool atoms = !d.atoms.empty();
    detail::drawAxes(cr, {left, pdfTop, pw, pdfHeight, d.lo, d.hi, 0.0, 1.05, "value",
                          atoms && peak > 0.0 ? "density, mass (peak = 1)"
                          : atoms             ? "probability (peak = 1)"
                                              : "density (peak = 1)",
                          font});

    // The TF: its colour as the background, its opacity as a black curve.
    double maxAlpha = 0.0;
    for (double a : tf.opacity) maxAlpha = std::max(maxAlpha, a);
    const double alphaTop = maxAlpha > 0.0 ? maxAlpha * 1.05 : 1.0;
    detail::fillTfColour(cr, tf, d.lo, d.hi, left, tfTop, cols, tfHeight);
    cairo_set_source_rgb(cr, 0.0, 0.0, 0.0);
    detail::strokeColumns(
        cr, left, cols,
        [&](int c) { return tfBottom - tfHeight * tf.opacityAt(xOf(c + 0.5)) / alphaTop; }, 1.5);
    detail::drawAxes(cr, {left, tfTop, pw, tfHeight, d.lo, d.hi, 0.0, alphaTop,
                          "value (TF colour behind)", "opacity", font});
    crp.reset();
    return detail::surfaceToImage(surface.get());
}

}  // namespace udvr
