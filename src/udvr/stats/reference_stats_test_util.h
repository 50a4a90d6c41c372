#pragma once
// Test-only reference implementations, written independently of the library from the formulas
// (numpy documentation, the KDE definition) and evaluated in long double.
#include <algorithm>
#include <cmath>
#include <vector>

namespace udvr::testref {

/// numpy.quantile(a, p), method "linear": virtual index g = p·(n−1), a[⌊g⌋] + (g − ⌊g⌋)·(a[⌊g⌋+1]
/// − a[⌊g⌋]), on an unsorted copy with nth_element.
inline long double numpyQuantile(std::vector<float> a, long double p) {
    const long double g = p * static_cast<long double>(a.size() - 1);
    const auto j = static_cast<std::size_t>(std::floor(g));
    std::nth_element(a.begin(), a.begin() + static_cast<std::ptrdiff_t>(j), a.end());
    const long double lo = a[j];
    if (j + 1 >= a.size()) return lo;
    const long double hi =
        *std::min_element(a.begin() + static_cast<std::ptrdiff_t>(j) + 1, a.end());
    return lo + (g - static_cast<long double>(j)) * (hi - lo);
}

/// The exact Gaussian-KDE CDF (1/n)·Σ ½·erfc(−(x − x_i)/(h√2)).
inline long double exactKdeCdf(const std::vector<float>& s, long double h, long double x) {
    long double sum = 0.0L;
    for (float xi : s) sum += 0.5L * std::erfc(-(x - xi) / (h * std::sqrt(2.0L)));
    return sum / static_cast<long double>(s.size());
}

/// F⁻¹(p) of the exact KDE CDF by 200 bisection steps.
inline long double bisectKdeQuantile(const std::vector<float>& s, long double h, long double p) {
    const auto [mn, mx] = std::minmax_element(s.begin(), s.end());
    long double lo = *mn - 50.0L * h, hi = *mx + 50.0L * h;
    for (int i = 0; i < 200; ++i) {
        const long double mid = 0.5L * (lo + hi);
        (exactKdeCdf(s, h, mid) < p ? lo : hi) = mid;
    }
    return 0.5L * (lo + hi);
}

}  // namespace udvr::testref
