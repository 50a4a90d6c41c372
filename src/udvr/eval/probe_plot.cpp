#include "udvr/eval/probe_plot.h"

#include <algorithm>
#include <cmath>

namespace udvr {
namespace {

void put(ImageRgba& im, int x, int y, float r, float g, float b) {
    if (x < 0 || y < 0 || x >= im.width || y >= im.height) return;
    float* p = im.pixel(x, y);
    p[0] = r, p[1] = g, p[2] = b, p[3] = 1.f;
}

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
    ImageRgba im;
    im.width = std::max(width, 64);
    im.height = std::max(height, 64);
    im.rgba.assign(static_cast<std::size_t>(im.width) * im.height * 4, 1.f);
    const ProbeDistribution& d = r.distribution;
    const int left = 8, right = im.width - 8, top = 8;
    const int pdfBottom = static_cast<int>(0.68 * im.height);
    const int tfTop = pdfBottom + 12, tfBottom = im.height - 8;
    const int cols = right - left;
    auto xOf = [&](int col) { return d.lo + (d.hi - d.lo) * col / cols; };

    // Continuous density per column = Δcdf / Δx, normalised to its peak.
    std::vector<double> dens(static_cast<std::size_t>(cols), 0.0);
    double peak = 0.0;
    if (d.continuousMass > 0)
        for (int c = 0; c < cols; ++c) {
            const double x0 = xOf(c), x1 = xOf(c + 1);
            dens[c] = (cdfAt(d, x1) - cdfAt(d, x0)) / (x1 - x0);
            peak = std::max(peak, dens[c]);
        }
    const int h = pdfBottom - top;
    for (int c = 0; c < cols && peak > 0; ++c) {
        const int bar = static_cast<int>(std::lround(h * dens[c] / peak));
        for (int y = pdfBottom - bar; y < pdfBottom; ++y) put(im, left + c, y, 0.55f, 0.7f, 0.95f);
        put(im, left + c, pdfBottom - bar, 0.1f, 0.25f, 0.7f);
    }
    double atomPeak = 0.0;
    for (double m : d.atomMass) atomPeak = std::max(atomPeak, m);
    for (std::size_t i = 0; i < d.atoms.size(); ++i) {
        const int col = static_cast<int>(std::lround((d.atoms[i] - d.lo) / (d.hi - d.lo) * cols));
        const int bar = static_cast<int>(std::lround(h * d.atomMass[i] / atomPeak));
        for (int y = pdfBottom - bar; y < pdfBottom; ++y)
            for (int dx = -1; dx <= 1; ++dx) put(im, left + col + dx, y, 0.85f, 0.1f, 0.1f);
    }
    for (int x = left; x < right; ++x) put(im, x, pdfBottom, 0.f, 0.f, 0.f);  // axis

    // TF strip: colour as background, opacity as a black curve.
    for (int c = 0; c < cols; ++c) {
        const double x = 0.5 * (xOf(c) + xOf(c + 1));
        const auto col = tf.colorAt(x);
        for (int y = tfTop; y < tfBottom; ++y)
            put(im, left + c, y, static_cast<float>(col[0]), static_cast<float>(col[1]),
                static_cast<float>(col[2]));
        const int ya =
            tfBottom - 1 - static_cast<int>(std::lround(tf.opacityAt(x) * (tfBottom - tfTop - 1)));
        put(im, left + c, ya, 0.f, 0.f, 0.f);
        put(im, left + c, ya + 1, 0.f, 0.f, 0.f);
    }
    return im;
}

}  // namespace udvr
