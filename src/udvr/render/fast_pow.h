#pragma once
// A fast t^e for t ∈ [0, 1] (the opacity correction 1 − (1 − α)^(Δ/u), SPEC §5) without libm's
// pow: log2 by exponent extraction and the atanh series on the mantissa reduced to [√½, √2),
// exp2 by rounding to the nearest integer and a degree-7 Taylor polynomial on [−½, ½], all in
// double. Relative error < 1e−8 for exponents e ≤ 64 (tested against std::pow), so the float
// result matches powf up to float rounding. Internal to render/.
#include <bit>
#include <cmath>
#include <cstdint>

namespace udvr::detail {

/// log2(t) for a finite t > 0 (no denormals: the callers pass 1 − α with α a float in [0, 1],
/// a multiple of 2^−24 or 0).
inline double fastLog2(double t) {
    const std::uint64_t bits = std::bit_cast<std::uint64_t>(t);
    int e = static_cast<int>((bits >> 52) & 0x7ff) - 1023;
    double m = std::bit_cast<double>((bits & 0x000fffffffffffffULL) | 0x3ff0000000000000ULL);
    if (m > 1.4142135623730951) {
        m *= 0.5;
        ++e;
    }
    // ln m = 2 atanh(s), s = (m − 1)/(m + 1) ∈ [−0.172, 0.172]; terms to s^13 (error < 1e−12).
    const double s = (m - 1.0) / (m + 1.0), s2 = s * s;
    const double p =
        1.0 + s2 * (1.0 / 3 +
                    s2 * (1.0 / 5 + s2 * (1.0 / 7 + s2 * (1.0 / 9 + s2 * (1.0 / 11 + s2 / 13)))));
    return static_cast<double>(e) + (2.0 * 1.4426950408889634) * s * p;
}

/// 2^y for y ≤ 0 (results below 2^−1000 flush to 0).
inline double fastExp2(double y) {
    if (!(y > -1000.0)) return 0.0;
    const double n = std::nearbyint(y);
    const double f = (y - n) * 0.6931471805599453;  // e^f, |f| ≤ 0.347: Taylor to f^8
    const double p =
        1.0 +
        f * (1.0 + f * (1.0 / 2 +
                        f * (1.0 / 6 +
                             f * (1.0 / 24 +
                                  f * (1.0 / 120 +
                                       f * (1.0 / 720 + f * (1.0 / 5040 + f * (1.0 / 40320))))))));
    const std::int64_t ni = static_cast<std::int64_t>(n);
    return p * std::bit_cast<double>(static_cast<std::uint64_t>(ni + 1023) << 52);
}

/// t^e for t ∈ [0, 1], e > 0.
inline float fastPowUnit(float t, float e) {
    if (!(t > 0.f)) return 0.f;
    return static_cast<float>(fastExp2(static_cast<double>(e) * fastLog2(static_cast<double>(t))));
}

}  // namespace udvr::detail
