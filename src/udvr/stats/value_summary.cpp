#include "udvr/stats/value_summary.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <map>

#include "udvr/util/check.h"

namespace udvr {

double ValueSummary::percentile(double p) const {
    for (std::size_t i = 0; i < kSummaryPercentiles.size(); ++i)
        if (kSummaryPercentiles[i] == p) return percentiles[i];
    UDVR_FAIL("percentile " << p << " is not one of the summary's");
}

std::vector<double> percentiles(std::span<const float> values, std::span<const double> p) {
    UDVR_CHECK_MSG(!values.empty(), "percentiles of no values");
    std::vector<float> work(values.begin(), values.end());
    const std::size_t n = work.size();
    // Order statistics selected so far, by index. Each selection partitions only the gap between
    // its selected neighbours, so a handful of percentiles cost O(n) together.
    std::map<std::size_t, float> selected;
    auto orderStatistic = [&](std::size_t k) -> double {
        const auto next = selected.lower_bound(k);
        if (next != selected.end() && next->first == k) return next->second;
        const std::size_t hi = next == selected.end() ? n : next->first;
        const std::size_t lo = next == selected.begin() ? 0 : std::prev(next)->first + 1;
        std::nth_element(work.begin() + static_cast<std::ptrdiff_t>(lo),
                         work.begin() + static_cast<std::ptrdiff_t>(k),
                         work.begin() + static_cast<std::ptrdiff_t>(hi));
        selected.emplace(k, work[k]);
        return work[k];
    };
    std::vector<double> out(p.size());
    for (std::size_t i = 0; i < p.size(); ++i) {
        UDVR_CHECK(p[i] >= 0.0 && p[i] <= 100.0);
        const double rank = static_cast<double>(n - 1) * p[i] / 100.0;
        const auto k = static_cast<std::size_t>(std::floor(rank));
        const double f = rank - static_cast<double>(k);
        const double below = orderStatistic(k);
        const double above = k + 1 < n ? orderStatistic(k + 1) : below;
        out[i] = below + f * (above - below);
    }
    return out;
}

ValueSummary summarizeValues(std::span<const float> values) {
    UDVR_CHECK_MSG(!values.empty(), "a summary of no values");
    ValueSummary s;
    s.count = values.size();
    double sum = 0.0, lo = values[0], hi = values[0];
    for (float v : values) {
        sum += v;
        lo = std::min(lo, static_cast<double>(v));
        hi = std::max(hi, static_cast<double>(v));
    }
    s.min = lo;
    s.max = hi;
    s.mean = sum / static_cast<double>(s.count);
    double ss = 0.0;  // two passes: no cancellation for large offsets
    for (float v : values) ss += (v - s.mean) * (v - s.mean);
    s.stddev = std::sqrt(ss / static_cast<double>(s.count));
    const std::vector<double> q = percentiles(values, kSummaryPercentiles);
    std::copy(q.begin(), q.end(), s.percentiles.begin());
    return s;
}

std::array<double, 2> robustRange(const ValueSummary& s) {
    double lo = s.percentile(0.5), hi = s.percentile(99.5);
    if (!(hi > lo)) {
        lo = s.min;
        hi = s.max;
    }
    if (!(hi > lo)) {
        // A constant: ±0.5 around it, or a relative margin where ±0.5 would round away (a
        // constant 1e17 gave an empty range and an internal check, issue 34).
        const double half = std::max(0.5, 1e-6 * std::max(std::abs(s.min), std::abs(s.max)));
        lo = s.min - half;
        hi = s.max + half;
    }
    return {lo, hi};
}

Histogram histogramOf(std::span<const float> values, double lo, double hi, int bins) {
    if (bins < 1) UDVR_FAIL("a histogram needs at least one bin, got " << bins);
    if (!(lo < hi)) UDVR_FAIL("histogram range [" << lo << ", " << hi << "] is empty");
    Histogram h;
    h.lo = lo;
    h.hi = hi;
    h.counts.assign(static_cast<std::size_t>(bins), 0);
    const double scale = bins / (hi - lo);
    for (float v : values) {
        if (v < lo) {
            ++h.below;
        } else if (v > hi) {
            ++h.above;
        } else {
            const auto b =
                std::min(static_cast<long>((v - lo) * scale), static_cast<long>(bins - 1));
            ++h.counts[static_cast<std::size_t>(b)];
        }
    }
    return h;
}

}  // namespace udvr
