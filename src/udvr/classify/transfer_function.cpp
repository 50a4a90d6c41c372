#include "udvr/classify/transfer_function.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace udvr {
namespace {

// Piecewise-linear value of (xs, f) at x; right-continuous at steps, clamped at the ends.
template <class Get>
double piecewiseLinear(const std::vector<double>& xs, double x, Get f) {
    const std::size_t n = xs.size();
    if (x < xs.front()) return f(0);
    if (x >= xs.back()) return f(n - 1);
    // First point with xs[i] > x; the segment is [i-1, i]. At a step (xs[i-1]==xs[i]) upper_bound
    // skips both, so the later point holds from x on.
    std::size_t i =
        static_cast<std::size_t>(std::upper_bound(xs.begin(), xs.end(), x) - xs.begin());
    const double x0 = xs[i - 1], x1 = xs[i];
    const double t = (x - x0) / (x1 - x0);
    return f(i - 1) + t * (f(i) - f(i - 1));
}

}  // namespace

std::array<double, 3> TransferFunction1D::colorAt(double x) const {
    std::array<double, 3> c{};
    for (int ch = 0; ch < 3; ++ch)
        c[ch] = piecewiseLinear(colorX, x, [&](std::size_t i) { return color[i][ch]; });
    return c;
}

double TransferFunction1D::opacityAt(double x) const {
    return piecewiseLinear(opacityX, x, [&](std::size_t i) { return opacity[i]; });
}

Rgba TransferFunction1D::classify(double x) const {
    const double a = opacityAt(x);
    const auto c = colorAt(x);
    return Rgba{static_cast<float>(a * c[0]), static_cast<float>(a * c[1]),
                static_cast<float>(a * c[2]), static_cast<float>(a)};
}

std::pair<double, double> TransferFunction1D::domain() const {
    double lo = std::min(colorX.front(), opacityX.front());
    double hi = std::max(colorX.back(), opacityX.back());
    return {lo, hi};
}

std::vector<std::pair<double, double>> TransferFunction1D::nonZeroOpacityRanges() const {
    const double inf = std::numeric_limits<double>::infinity();
    std::vector<std::pair<double, double>> ranges;
    const std::size_t n = opacityX.size();
    auto add = [&](double lo, double hi) {
        if (!ranges.empty() && lo <= ranges.back().second)
            ranges.back().second = std::max(ranges.back().second, hi);
        else
            ranges.emplace_back(lo, hi);
    };
    if (opacity[0] > 0) add(-inf, opacityX[0]);
    for (std::size_t i = 0; i + 1 < n; ++i) {
        if (opacity[i] > 0 || opacity[i + 1] > 0) add(opacityX[i], opacityX[i + 1]);
    }
    if (opacity[n - 1] > 0) add(opacityX[n - 1], inf);
    return ranges;
}

void TransferFunction1D::validate() const {
    if (colorX.empty() || color.size() != colorX.size())
        UDVR_FAIL("transfer function: colour needs at least one point (x,r,g,b)");
    if (opacityX.empty() || opacity.size() != opacityX.size())
        UDVR_FAIL("transfer function: opacity needs at least one point (x,alpha)");
    for (std::size_t i = 0; i < colorX.size(); ++i) {
        if (!std::isfinite(colorX[i])) UDVR_FAIL("transfer function: colour x is not finite");
        if (i > 0 && colorX[i] < colorX[i - 1])
            UDVR_FAIL("transfer function: colour points must be sorted by x (point " << i << ")");
        for (double v : color[i])
            if (!(v >= 0.0 && v <= 1.0))
                UDVR_FAIL("transfer function: colour values must lie in [0,1] (point " << i << ")");
    }
    for (std::size_t i = 0; i < opacityX.size(); ++i) {
        if (!std::isfinite(opacityX[i])) UDVR_FAIL("transfer function: opacity x is not finite");
        if (i > 0 && opacityX[i] < opacityX[i - 1])
            UDVR_FAIL("transfer function: opacity points must be sorted by x (point " << i << ")");
        if (!(opacity[i] >= 0.0 && opacity[i] <= 1.0))
            UDVR_FAIL("transfer function: opacity must lie in [0,1] (point " << i << ")");
    }
}

}  // namespace udvr
