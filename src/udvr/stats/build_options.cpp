// `udvr build`'s options (build_model.h): their checks against the samples per voxel, the
// defaults that depend on the input, and the fitting of K and q to few samples.
#include <algorithm>
#include <cmath>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "udvr/stats/build_model.h"
#include "udvr/util/check.h"
#include "udvr/util/choice.h"

namespace udvr {

void validateBuildOptions(const BuildOptions& o, int n) {
    if (n < 2) UDVR_FAIL("build needs at least 2 samples per voxel, the input gives " << n);
    if (o.quantiles < 0 || o.quantiles > 1024)
        UDVR_FAIL("--quantiles " << o.quantiles
                                 << " is out of range; expected 1..1024 (or 0 to skip quantiles)");
    normalizedQuantileLevels(o.quantileLevels, o.quantiles, "--quantile-levels");
    if (o.gmmComponents < 0 || o.gmmComponents > kMaxGmmComponents)
        UDVR_FAIL("--gmm " << o.gmmComponents << " is out of range; expected 1.."
                           << kMaxGmmComponents << " components (or 0 to skip the GMM)");
    if (o.gmmComponents > n)
        UDVR_FAIL("--gmm " << o.gmmComponents << " needs at least " << o.gmmComponents
                           << " samples per voxel, the input has " << n << "; use --gmm " << n
                           << " or fewer");
    if (o.density == DensityEstimate::Kde) {
        if (o.bandwidth.rule == BandwidthRule::Fixed &&
            !(std::isfinite(o.bandwidth.fixed) && o.bandwidth.fixed > 0.0))
            UDVR_FAIL("--bandwidth " << o.bandwidth.fixed << " is not a positive finite number");
        if (o.tailEps != 0.0) {
            if (!(o.tailEps > 0.0 && o.tailEps < 0.5))
                UDVR_FAIL("--tail-eps " << o.tailEps << " is out of range; expected 0 < E < 0.5");
            // The tails must stay inside the outer quantiles: ε ≤ t_1 and 1 − ε ≥ t_{q−1}.
            const double outer =
                o.quantileLevels.size() > 2
                    ? std::min(o.quantileLevels[1], 1.0 - o.quantileLevels[o.quantiles - 1])
                    : 1.0 / o.quantiles;
            if (o.quantiles > 0 && o.tailEps > outer)
                UDVR_FAIL("--tail-eps "
                          << o.tailEps << " exceeds "
                          << (o.quantileLevels.size() > 2 ? "the outer quantiles' mass " : "1/q = ")
                          << outer << "; the tail boundaries would cross b_1");
        }
    } else if (o.tailEps != 0.0) {
        UDVR_FAIL("--tail-eps applies to --density kde only");
    }
}

NanPolicy parseNanPolicy(const std::string& name) {
    constexpr std::pair<std::string_view, NanPolicy> kNames[] = {{"error", NanPolicy::Error},
                                                                 {"skip", NanPolicy::Skip}};
    return parseChoice(name, kNames, "--nan");
}

DensityEstimate defaultDensity(bool bricks) {
    return bricks ? DensityEstimate::Kde : DensityEstimate::Empirical;
}

void checkDensityForInput(DensityEstimate density, double valueStep, const std::string& valueType) {
    if (density != DensityEstimate::Dequantized || valueStep > 0.0) return;
    UDVR_FAIL(
        "--density dequantized spreads each value over its quantisation step and needs an "
        "integer-typed input; this input holds "
        << (valueType.empty() ? std::string("floating-point") : valueType)
        << " values: use --density empirical or kde");
}

BuildFitNotes fitBuildOptionsToSamples(BuildOptions& opt, long long samples, bool gmmGiven,
                                       bool quantilesGiven) {
    const int n = static_cast<int>(std::min<long long>(samples, 1 << 30));
    BuildFitNotes notes;
    std::string& info = notes.info;
    if (n >= 2 && opt.gmmComponents > n && opt.gmmComponents <= kMaxGmmComponents) {
        if (gmmGiven)
            notes.warnings.push_back("--gmm " + std::to_string(opt.gmmComponents) +
                                     " needs at least " + std::to_string(opt.gmmComponents) +
                                     " samples per voxel, the input has " + std::to_string(n) +
                                     ": GMM K lowered from " + std::to_string(opt.gmmComponents) +
                                     " to " + std::to_string(n));
        else
            info += "GMM K lowered from " + std::to_string(opt.gmmComponents) + " to " +
                    std::to_string(n);
        opt.gmmComponents = n;
    }
    if (n >= 2 && opt.density == DensityEstimate::Empirical && opt.quantiles > n) {
        const std::string text = "the " + std::to_string(opt.quantiles + 1) +
                                 " quantile boundaries interpolate between only " +
                                 std::to_string(n) + " sample values";
        if (quantilesGiven)
            notes.warnings.push_back("--quantiles " + std::to_string(opt.quantiles) + " with " +
                                     std::to_string(n) + " samples per voxel: " + text);
        else
            info += (info.empty() ? "" : "; ") + text;
    }
    validateBuildOptions(opt, n);
    return notes;
}

}  // namespace udvr
