#pragma once
// Per-voxel estimators on the n samples of one voxel (SPEC §2), each taking the samples sorted
// ascending: moments, numpy-style empirical quantiles, and the Gaussian KDE with its bandwidth
// rules and quantile inversion. Arithmetic is in double; inputs and outputs are data units.
#include <span>
#include <string>

namespace udvr {

/// Which density estimate the quantile boundaries come from (SPEC §2; Dequantized: issue 12).
enum class DensityEstimate { Empirical, Kde, Dequantized };

/// KDE bandwidth rule (SPEC §2).
enum class BandwidthRule { Silverman, Scott, Fixed };

/// Bandwidth choice: a rule, and h in data units for Fixed.
struct KdeBandwidth {
    BandwidthRule rule = BandwidthRule::Silverman;
    double fixed = 0.0;  // h for BandwidthRule::Fixed, data units, > 0
};

/// Sample moments of one voxel.
struct SampleMoments {
    double mean = 0.0;
    double stddev = 0.0;  // ddof = 1; 0 for n = 1
    double min = 0.0;
    double max = 0.0;
};

/// Parse "empirical" | "kde" | "dequantized"; throws UdvrError otherwise.
DensityEstimate parseDensityEstimate(const std::string& name);
/// The name parseDensityEstimate reads ("empirical" …), as the model's `density` field data.
std::string densityEstimateName(DensityEstimate d);
/// Parse "silverman" | "scott" | a positive finite number (h in data units); throws UdvrError.
KdeBandwidth parseBandwidth(const std::string& text);

/// Mean, ddof=1 standard deviation (two-pass), min and max of sorted samples (n ≥ 1).
SampleMoments sampleMoments(std::span<const float> sorted);

/// numpy's default ("linear", Hyndman–Fan type 7) quantile at p ∈ [0,1] of sorted samples:
/// position (n−1)·p, linear interpolation between its neighbours. p=0 → min, p=1 → max.
double empiricalQuantile(std::span<const float> sorted, double p);

/// Quantiles of the dequantised sample: each sorted sample x_i spread uniformly over
/// [x_i − s/2, x_i + s/2] (s > 0 the quantisation step, data units), so F(x) = (1/n)·Σ
/// clamp((x − x_i)/s + ½, 0, 1), piecewise linear. out[k] = F⁻¹(levels[k]) exactly, with
/// F⁻¹(p) = inf{x : F(x) ≥ p} (the left end where F is flat at p), F⁻¹(0) = min − s/2 and
/// F⁻¹(1) = max + s/2; levels ascending in [0, 1]. One O(n + m) walk over the 2n breakpoints.
void dequantizedQuantiles(std::span<const float> sorted, double step,
                          std::span<const double> levels, std::span<double> out);

/// KDE bandwidth h (data units) by the rule of SPEC §2 for sorted samples with ddof=1 std
/// `stddev`: Silverman's robust 0.9·min(σ, IQR/1.34)·n^(−1/5) (σ alone where IQR = 0), Scott's
/// σ·n^(−1/5), or the fixed value. Returns 0 for a constant voxel under a data-driven rule.
double kdeBandwidth(std::span<const float> sorted, double stddev, const KdeBandwidth& bw);

/// The Gaussian KDE's CDF F(x) = (1/n)·Σ Φ((x − x_i)/h) and its density f(x); h > 0.
struct KdeCdfPdf {
    double cdf;
    double pdf;
};
KdeCdfPdf kdeCdfPdf(std::span<const float> sorted, double h, double x);

/// F⁻¹(p) for p ∈ (0,1): Newton on F from `guess` with a bisection fallback inside a bracket
/// that always contains the root; converges to ~1e−12 of the sample range + h.
double kdeQuantile(std::span<const float> sorted, double h, double p, double guess);

}  // namespace udvr
