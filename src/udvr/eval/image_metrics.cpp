#include "udvr/eval/image_metrics.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "udvr/util/check.h"

namespace udvr {
namespace {

void checkSameSize(const ImageRgba& a, const ImageRgba& b) {
    if (a.width != b.width || a.height != b.height)
        UDVR_FAIL("images differ in size: " << a.width << "x" << a.height << " vs " << b.width
                                            << "x" << b.height
                                            << " (render both at the same --size)");
    const std::size_t n = static_cast<std::size_t>(a.width) * a.height * 4;
    if (a.rgba.size() != n || b.rgba.size() != n)
        UDVR_FAIL("image pixel buffer does not match its size");
}

}  // namespace

std::vector<float> pixelDifferences(const ImageRgba& model, const ImageRgba& truth) {
    checkSameSize(model, truth);
    const std::size_t n = static_cast<std::size_t>(model.width) * model.height;
    std::vector<float> d(n);
    for (std::size_t i = 0; i < n; ++i) {
        const float* m = model.rgba.data() + 4 * i;
        const float* t = truth.rgba.data() + 4 * i;
        // Mean of R,G,B in double so the metric does not depend on summation order.
        const double mm = (static_cast<double>(m[0]) + m[1] + m[2]) / 3.0;
        const double tm = (static_cast<double>(t[0]) + t[1] + t[2]) / 3.0;
        d[i] = static_cast<float>(std::abs(mm - tm));
    }
    return d;
}

double imageRmse(const ImageRgba& model, const ImageRgba& truth) {
    checkSameSize(model, truth);
    const std::size_t n = static_cast<std::size_t>(model.width) * model.height;
    if (n == 0) return 0.0;
    double sum = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        const float* m = model.rgba.data() + 4 * i;
        const float* t = truth.rgba.data() + 4 * i;
        const double d = (static_cast<double>(m[0]) + m[1] + m[2]) / 3.0 -
                         (static_cast<double>(t[0]) + t[1] + t[2]) / 3.0;
        sum += d * d;
    }
    return std::sqrt(sum / static_cast<double>(n));
}

void differenceColor(double t, float rgb[3]) {
    // Three anchors, linear in RGB: blue (low), near-white (middle), yellow (high).
    static constexpr float kLow[3] = {0.13f, 0.29f, 0.80f};
    static constexpr float kMid[3] = {0.95f, 0.95f, 0.95f};
    static constexpr float kHigh[3] = {0.98f, 0.82f, 0.05f};
    t = std::clamp(std::isfinite(t) ? t : 1.0, 0.0, 1.0);
    const float* a = t < 0.5 ? kLow : kMid;
    const float* b = t < 0.5 ? kMid : kHigh;
    const float u = static_cast<float>(t < 0.5 ? 2.0 * t : 2.0 * t - 1.0);
    for (int c = 0; c < 3; ++c) rgb[c] = a[c] + u * (b[c] - a[c]);
}

ImageRgba differenceImage(const ImageRgba& model, const ImageRgba& truth, double maxDiff) {
    const std::vector<float> d = pixelDifferences(model, truth);
    double scale = maxDiff;
    if (!(scale > 0.0)) {
        scale = 0.0;
        for (float v : d) scale = std::max(scale, static_cast<double>(v));
    }
    ImageRgba out;
    out.width = model.width;
    out.height = model.height;
    out.rgba.resize(d.size() * 4);
    for (std::size_t i = 0; i < d.size(); ++i) {
        float* p = out.rgba.data() + 4 * i;
        differenceColor(scale > 0.0 ? d[i] / scale : 0.0, p);
        p[3] = 1.f;
    }
    return out;
}

namespace {
// Flood-fill the pieces of pixels where inside(x, y), 8- or 4-connected; f(size, touchesBorder)
// per piece.
template <class Inside, class Piece>
void floodPieces(int w, int h, bool eight, const Inside& inside, const Piece& piece) {
    std::vector<char> seen(static_cast<std::size_t>(w) * h, 0);
    std::vector<std::pair<int, int>> stack;
    for (int y0 = 0; y0 < h; ++y0)
        for (int x0 = 0; x0 < w; ++x0) {
            const std::size_t k0 = static_cast<std::size_t>(y0) * w + x0;
            if (seen[k0] || !inside(x0, y0)) continue;
            std::size_t size = 0;
            bool border = false;
            seen[k0] = 1;
            stack.assign(1, {x0, y0});
            while (!stack.empty()) {
                const auto [x, y] = stack.back();
                stack.pop_back();
                ++size;
                border = border || x == 0 || y == 0 || x == w - 1 || y == h - 1;
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx) {
                        if ((dx == 0 && dy == 0) || (!eight && dx != 0 && dy != 0)) continue;
                        const int nx = x + dx, ny = y + dy;
                        if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
                        const std::size_t k = static_cast<std::size_t>(ny) * w + nx;
                        if (seen[k] || !inside(nx, ny)) continue;
                        seen[k] = 1;
                        stack.push_back({nx, ny});
                    }
            }
            piece(size, border);
        }
}
}  // namespace

MaskComponents opaqueComponents(const ImageRgba& image, float alphaThreshold) {
    const int w = image.width, h = image.height;
    const auto opaque = [&](int x, int y) {
        return image.rgba[(static_cast<std::size_t>(y) * w + x) * 4 + 3] > alphaThreshold;
    };
    MaskComponents r;
    floodPieces(w, h, true, opaque, [&](std::size_t size, bool) {
        ++r.count;
        r.pixels += size;
        r.largest = std::max(r.largest, size);
    });
    floodPieces(
        w, h, false, [&](int x, int y) { return !opaque(x, y); },
        [&](std::size_t, bool border) { r.holes += border ? 0 : 1; });
    return r;
}

}  // namespace udvr
