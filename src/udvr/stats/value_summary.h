#pragma once
// Summaries of a volume's values for `udvr info`, default transfer functions and histograms:
// range, moments, percentiles (NumPy's default "linear" rule) and a fixed-bin histogram.
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace udvr {

/// The percentiles ValueSummary reports, in percent.
inline constexpr std::array<double, 9> kSummaryPercentiles{0.5, 1, 5, 25, 50, 75, 95, 99, 99.5};

struct ValueSummary {
    std::size_t count = 0;
    double min = 0.0, max = 0.0;
    double mean = 0.0, stddev = 0.0;  // population standard deviation (ddof = 0)
    std::array<double, kSummaryPercentiles.size()> percentiles{};  // at kSummaryPercentiles
    /// The percentile p (one of kSummaryPercentiles); throws otherwise.
    double percentile(double p) const;
};

/// Percentiles p ∈ [0, 100] of `values` with linear interpolation between order statistics
/// (x_(k) + f·(x_(k+1) − x_(k)) at rank (n−1)·p/100, as numpy.percentile's default). Values must
/// be finite and non-empty. O(n) per percentile (selection on a copy).
std::vector<double> percentiles(std::span<const float> values, std::span<const double> p);

/// Count, range, mean, standard deviation and kSummaryPercentiles of finite, non-empty values.
ValueSummary summarizeValues(std::span<const float> values);

/// The robust range a default TF spans: [p0.5, p99.5], widened to [min, max] when that is
/// empty (a volume with mostly one value), and to [v − h, v + h] for a constant volume, h = 0.5 or
/// 1e−6·|v| where that is larger.
std::array<double, 2> robustRange(const ValueSummary& summary);

struct Histogram {
    double lo = 0.0, hi = 1.0;  // bin b covers [lo + b·w, lo + (b+1)·w), w = (hi−lo)/bins
    std::vector<std::uint64_t> counts;   // the last bin also holds x == hi
    std::uint64_t below = 0, above = 0;  // values outside [lo, hi]
};

/// Histogram of `values` over [lo, hi] (lo < hi) in `bins` ≥ 1 equal bins.
Histogram histogramOf(std::span<const float> values, double lo, double hi, int bins);

}  // namespace udvr
