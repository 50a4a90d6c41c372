#include "udvr/stats/voxel_stats.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>

#include "udvr/util/check.h"
#include "udvr/util/choice.h"
#include "udvr/util/fast_math.h"
#include "udvr/util/lanes.h"

namespace udvr {

DensityEstimate parseDensityEstimate(const std::string& name) {
    constexpr std::pair<std::string_view, DensityEstimate> kNames[] = {
        {"empirical", DensityEstimate::Empirical},
        {"kde", DensityEstimate::Kde},
        {"dequantized", DensityEstimate::Dequantized}};
    return parseChoice(name, kNames, "--density");
}

std::string densityEstimateName(DensityEstimate d) {
    switch (d) {
        case DensityEstimate::Kde:
            return "kde";
        case DensityEstimate::Dequantized:
            return "dequantized";
        case DensityEstimate::Empirical:
            break;
    }
    return "empirical";
}

KdeBandwidth parseBandwidth(const std::string& text) {
    if (text == "silverman") return {BandwidthRule::Silverman, 0.0};
    if (text == "scott") return {BandwidthRule::Scott, 0.0};
    const char* begin = text.c_str();
    char* end = nullptr;
    errno = 0;
    const double h = std::strtod(begin, &end);
    if (text.empty() || end != begin + text.size() || errno != 0 || !std::isfinite(h) || h <= 0.0)
        UDVR_FAIL("--bandwidth '" << text
                                  << "' is not valid; expected silverman, scott or a positive "
                                     "number (h in data units)");
    return {BandwidthRule::Fixed, h};
}

SampleMoments sampleMoments(std::span<const float> sorted) {
    UDVR_CHECK(!sorted.empty());
    const std::size_t n = sorted.size();
    double sum = 0.0;
    for (float v : sorted) sum += v;
    SampleMoments m;
    m.mean = sum / static_cast<double>(n);
    // Two-pass variance: Σ(x − x̄)² is not prone to the cancellation of Σx² − n·x̄².
    double ss = 0.0, corr = 0.0;
    for (float v : sorted) {
        const double d = v - m.mean;
        ss += d * d;
        corr += d;
    }
    if (n > 1) {
        ss -= corr * corr / static_cast<double>(n);  // corrects the rounding of the mean
        m.stddev = std::sqrt(std::max(0.0, ss) / static_cast<double>(n - 1));
    }
    m.min = sorted.front();
    m.max = sorted.back();
    return m;
}

double empiricalQuantile(std::span<const float> sorted, double p) {
    UDVR_CHECK(!sorted.empty());
    const std::size_t n = sorted.size();
    const double pos = static_cast<double>(n - 1) * p;
    if (pos <= 0.0) return sorted.front();
    const std::size_t lo = static_cast<std::size_t>(pos);
    if (lo >= n - 1) return sorted.back();
    const double frac = pos - static_cast<double>(lo);
    const double a = sorted[lo], b = sorted[lo + 1];
    return a + frac * (b - a);
}

void dequantizedQuantiles(std::span<const float> sorted, double step,
                          std::span<const double> levels, std::span<double> out) {
    UDVR_CHECK(!sorted.empty() && step > 0.0 && out.size() == levels.size());
    const std::size_t n = sorted.size();
    const double half = 0.5 * step;
    const double slopePerActive = 1.0 / (static_cast<double>(n) * step);  // dF/dx of one uniform
    // Walk the breakpoints: lower ends x_i − s/2 and upper ends x_i + s/2, each sorted as x is.
    // Between two, F rises linearly with slope active·slopePerActive.
    std::size_t lower = 0, upper = 0, k = 0;
    int active = 0;
    double x = sorted[0] - half, cdf = 0.0;
    while (k < levels.size() && levels[k] <= 0.0) out[k++] = x;
    while (k < levels.size() && upper < n) {
        const double nextLower = lower < n ? sorted[lower] - half : 0.0;
        const double nextUpper = sorted[upper] + half;
        const bool opens = lower < n && nextLower <= nextUpper;
        const double next = opens ? nextLower : nextUpper;
        const double slope = active * slopePerActive;
        const double cdfNext = cdf + slope * (next - x);
        // Levels reached on (x, next]: where F crosses p on this linear piece.
        while (k < levels.size() && levels[k] < 1.0 && levels[k] <= cdfNext && slope > 0.0) {
            out[k] = std::min(next, x + std::max(0.0, levels[k] - cdf) / slope);
            ++k;
        }
        x = next;
        cdf = cdfNext;
        if (opens) {
            ++lower;
            ++active;
        } else {
            ++upper;
            --active;
        }
    }
    // p = 1 (and any p that rounding left above the summed F): the support's upper end.
    for (; k < levels.size(); ++k) out[k] = static_cast<double>(sorted[n - 1]) + half;
}

double kdeBandwidth(std::span<const float> sorted, double stddev, const KdeBandwidth& bw) {
    if (bw.rule == BandwidthRule::Fixed) return bw.fixed;
    const double nFactor = std::pow(static_cast<double>(sorted.size()), -0.2);
    if (bw.rule == BandwidthRule::Scott) return stddev * nFactor;
    // Silverman's robust rule (Silverman 1986, Eq. 3.31).
    const double iqr = empiricalQuantile(sorted, 0.75) - empiricalQuantile(sorted, 0.25);
    const double spread = iqr > 0.0 ? std::min(stddev, iqr / 1.34) : stddev;
    return 0.9 * spread * nFactor;
}

namespace {
// Beyond 9 bandwidths a kernel's Φ is 0 or 1 to 1e−19, below double resolution of F.
constexpr double kKernelReach = 9.0;
}  // namespace

KdeCdfPdf kdeCdfPdf(std::span<const float> sorted, double h, double x) {
    const std::size_t n = sorted.size();
    const auto lo = static_cast<float>(x - kKernelReach * h);
    const auto hi = static_cast<float>(x + kKernelReach * h);
    // Samples above x + reach·h contribute Φ ≈ 0; those below x − reach·h contribute 1.
    const std::size_t first = static_cast<std::size_t>(
        std::lower_bound(sorted.begin(), sorted.end(), lo) - sorted.begin());
    const std::size_t last = static_cast<std::size_t>(
        std::upper_bound(sorted.begin() + static_cast<std::ptrdiff_t>(first), sorted.end(), hi) -
        sorted.begin());
    const double invH = 1.0 / h;
    // 8 kernels per step (fast_math.h); the lanes past `last` in the final step are masked off.
    using lanes::V8d;
    const V8d xv = lanes::splat<V8d>(x), invHv = lanes::splat<V8d>(invH);
    V8d cdf{}, pdf{};
    for (std::size_t i = first; i < last; i += 8) {
        const std::size_t m = std::min<std::size_t>(8, last - i);
        lanes::V8f s{};
        std::memcpy(&s, sorted.data() + i, m * sizeof(float));
        const V8d u = (xv - __builtin_convertvector(s, V8d)) * invHv;
        const NormalAt<V8d> normal = normalAt(u, detail::ExpNonPositiveOf{});
        V8d c = normal.cdf, p = normal.pdf;
        if (m < 8) {
            const V8d lane{0, 1, 2, 3, 4, 5, 6, 7};
            const auto valid = lane < static_cast<double>(m);
            c = valid ? c : V8d{};
            p = valid ? p : V8d{};
        }
        cdf += c;
        pdf += p;
    }
    const double invN = 1.0 / static_cast<double>(n);
    return {(static_cast<double>(first) + detail::sumLanes(cdf)) * invN,
            detail::sumLanes(pdf) * invN * invH};
}

double kdeQuantile(std::span<const float> sorted, double h, double p, double guess) {
    UDVR_CHECK(!sorted.empty() && h > 0.0 && p > 0.0 && p < 1.0);
    // Bracket: F(lo) ≤ Φ(−40) ≈ 0 < p and F(hi) ≥ 1 − Φ(−40) > p for any p in (0, 1) we use.
    double lo = sorted.front() - 40.0 * h;
    double hi = sorted.back() + 40.0 * h;
    const double tol = 1e-12 * (hi - lo);
    // After a Newton step δ the error is ≈ δ²·|f′/(2f)| ≤ δ²·20/h inside the bracket (|u| ≤ 40
    // for every kernel), so a step ≤ 1e−6·h leaves < 2e−11·h, i.e. |F − p| < 1e−11: stop there
    // rather than spend one more evaluation confirming it.
    const double newtonStop = 1e-6 * h;
    double x = std::clamp(guess, lo, hi);
    for (int it = 0; it < 200; ++it) {
        const KdeCdfPdf r = kdeCdfPdf(sorted, h, x);
        const double g = r.cdf - p;
        if (g == 0.0) return x;
        if (g < 0.0)
            lo = x;
        else
            hi = x;
        double next = r.pdf > 0.0 ? x - g / r.pdf : lo - 1.0;
        if (!(next > lo && next < hi)) {
            next = 0.5 * (lo + hi);  // Newton left the bracket
        } else if (std::fabs(next - x) <= newtonStop) {
            return next;
        }
        if (std::fabs(next - x) <= tol || hi - lo <= tol) return next;
        x = next;
    }
    return x;
}

}  // namespace udvr
