#pragma once
// Vector math for the per-voxel estimators of stats/ and the batched ray loop of render/, over the
// vectors of util/lanes.h (`lanes::Vec<E, W>` of any width, `lanes::Vf`; one or more registers per
// vector). GCC does not vectorise the floating-point reductions and transcendental calls of EM and
// of the KDE sums by itself, so the hot loops are written on these types directly. The functions
// are templates over the vector type: 16-lane vectors give two independent dependency chains per
// operation on AVX2 (or one zmm on AVX-512), which the latency-bound EM loop needs. Error bounds
// are tested in fast_math_test.cpp.
#include <bit>
#include <cmath>
#include <type_traits>

#include "udvr/util/lanes.h"
#include "udvr/util/normal_cdf.h"

namespace udvr::detail {

// Every lane = s: the one `splat` of util/lanes.h, for vectors of any width.
using lanes::splat;

/// c₀xⁿ + c₁xⁿ⁻¹ + … + cₙ by Horner's scheme, highest degree first (p ← p·x + cᵢ, in that
/// order of operations).
template <class V, class S, class... C>
inline V horner(V x, S first, C... rest) {
    V p = splat<V>(first);
    ((p = p * x + rest), ...);
    return p;
}

/// expNonPositive clamps its argument here: e^−87 ≈ 1.6e−38 is nothing next to a row maximum
/// of e^0 = 1 (and keeps a dead mixture component, log π = −∞, dead: its responsibilities sum to
/// < n·2e−38, far below the 1e−6 at which EM declares a component empty).
inline constexpr float kExpClampBelow = -87.f;

/// (e^r − 1)/r for float lanes |r| ≤ ln2/2: degree-5 Taylor polynomial (so r·it + 1 is e^r's
/// degree-6 one, truncation r⁷/7! < 1.2e−7); e^r − 1 = r·expm1OverX(r) without cancellation.
template <class VF>
inline VF expm1OverX(VF r) {
    return horner(r, 1.f / 720.f, 1.f / 120.f, 1.f / 24.f, 1.f / 6.f, 0.5f, 1.f);
}

/// e^max(x, −87) for float lanes x ≤ 0 (−∞ allowed): relative error < 2.5e−7.
/// x = n·ln2 + r, |r| ≤ ln2/2, e^r by its degree-6 Taylor polynomial (truncation r⁷/7! < 1.2e−7),
/// 2^n from the bits of the rounding shifter. Horner's scheme: the EM loop is throughput-bound.
template <class VF>
inline VF expNonPositive(VF x) {
    using VI = decltype(x < x);
    const VF clamp = splat<VF>(kExpClampBelow);
    const VF xc = lanes::selectBits(lanes::less(x, clamp), clamp, x);
    const VF shifter = splat<VF>(0x1.8p23f);  // adding it rounds to an integer
    const VF t = xc * 1.44269504f + shifter;  // low mantissa bits: 2^22 + n
    const VF n = t - shifter;
    const VF r = (xc - n * 0.693145752f) - n * 1.42860677e-6f;  // ln2 = hi + lo
    const VF p = expm1OverX(r) * r + 1.f;
    // (2^22 + n + 127) << 23 keeps the low 9 bits, n + 127 ∈ [1, 127]: the exponent of 2^n.
    const VI bits = (std::bit_cast<VI>(t) + 127) << 23;
    return p * std::bit_cast<VF>(bits);
}

/// Splits positive normal floats s = 2^e·f with f ∈ [1, 2): returns f, adds e to `expo`.
template <class VF, class VI>
inline VF splitExponent(VF s, VI& expo) {
    const VI bits = std::bit_cast<VI>(s);
    expo += (bits >> 23) - 127;
    return std::bit_cast<VF>((bits & 0x007FFFFF) | 0x3F800000);
}

/// log((1 + t)/(1 − t)) = 2·atanh(t) for float lanes |t| ≤ 0.2: series to t⁹ (truncation
/// < 4e−9). With t = −a/(2 − a) it is log(1 − a) without forming 1 − a.
template <class VF>
inline VF logOfAtanhArg(VF t) {
    return 2.f * t * horner(t * t, 1.f / 9.f, 1.f / 7.f, 1.f / 5.f, 1.f / 3.f, 1.f);
}

/// log(s) for positive normal float lanes; absolute error < 1.5e−7 + 6e−8·|log s| (the float
/// rounding of the result) with FMA, up to twice that without. s = 2^e·f with f ∈ [√½, √2), log f =
/// 2·atanh(t), t = (f−1)/(f+1), |t| ≤ 0.172, series to t⁹ (truncation < 1e−9).
template <class VF>
inline VF logPositive(VF s) {
    using VI = decltype(s < s);
    VI expo{};
    VF f = splitExponent(s, expo);
    VF e = __builtin_convertvector(expo, VF);
    const auto big = f > 1.41421356f;
    f = big ? f * 0.5f : f;
    e = big ? e + 1.f : e;
    return e * 0.693147181f + logOfAtanhArg((f - 1.f) / (f + 1.f));
}

/// log(s) for positive normal double lanes; absolute error < 1e−15·(1 + |log s|).
/// s = 2^e·f with f ∈ [√½, √2), log f = 2·atanh(t), t = (f−1)/(f+1), |t| ≤ 0.172, series to t¹⁹
/// (truncation < 4e−17).
template <class VD>
inline VD logPositiveD(VD s) {
    using VL = decltype(s < s);
    const VL bits = std::bit_cast<VL>(s);
    VD e = __builtin_convertvector((bits >> 52) - 1023, VD);
    VD f = std::bit_cast<VD>((bits & 0x000FFFFFFFFFFFFFLL) | 0x3FF0000000000000LL);
    const VL big = lanes::less(splat<VD>(1.4142135623730951), f);
    f = lanes::selectBits(big, f * 0.5, f);
    e = lanes::selectBits(big, e + 1.0, e);
    const VD t = (f - 1.0) / (f + 1.0);
    const VD t2 = t * t;
    const VD p = horner(t2, 1.0 / 19, 1.0 / 17, 1.0 / 15, 1.0 / 13, 1.0 / 11, 1.0 / 9, 1.0 / 7,
                        1.0 / 5, 1.0 / 3, 1.0);
    return e * 0.69314718055994531 + 2.0 * t * p;
}

/// e^x in double for x ≤ 0 (−∞ allowed): relative error < 3e−13 for x ≥ −708, exactly 0
/// below. x = n·ln2 + r, |r| ≤ ln2/2, e^r by its degree-10 Taylor polynomial (truncation
/// r¹¹/11! < 2.2e−13), 2^n from the bits of the rounding shifter.
template <class VD>
inline VD expNonPositiveD(VD x) {
    using VL = decltype(x < x);
    const auto flush = x < -708.0;
    const VD xc = flush ? splat<VD>(-708.0) : x;
    const VD shifter = splat<VD>(0x1.8p52);
    const VD t = xc * 1.4426950408889634 + shifter;  // low mantissa bits: 2^51 + n
    const VD n = t - shifter;
    // ln2 = hi + lo with n·hi exact (hi has 21 trailing zero bits; fdlibm's split).
    const VD r = (xc - n * 6.93147180369123816490e-01) - n * 1.90821492927058770002e-10;
    const VD p = horner(r, 1.0 / 3628800.0, 1.0 / 362880.0, 1.0 / 40320.0, 1.0 / 5040.0,
                        1.0 / 720.0, 1.0 / 120.0, 1.0 / 24.0, 1.0 / 6.0, 0.5, 1.0, 1.0);
    // (2^51 + n + 1023) << 52 keeps the low 12 bits, n + 1023 ∈ [1, 1023]: the exponent of 2^n.
    const VL bits = (std::bit_cast<VL>(t) + 1023) << 52;
    const VD v = p * std::bit_cast<VD>(bits);
    return flush ? VD{} : v;
}

/// e^x for x ≤ 0 on any real type: std::exp on scalars, expNonPositiveD on double lanes,
/// expNonPositive on float lanes (relative error < 2.5e−7). normalAt's exponential on lanes.
struct ExpNonPositiveOf {
    template <class T>
    UDVR_CPU_GPU T operator()(T x) const {
        if constexpr (std::is_arithmetic_v<T>)
            return std::exp(x);
        else if constexpr (std::is_same_v<lanes::ScalarOf<T>, double>)
            return expNonPositiveD(x);
        else
            return expNonPositive(x);
    }
};

/// Φ(u) and φ(u) on float lanes for |u| < kNormalNearRange only (the fast box spline's nodes,
/// classify/expected_tf.h): Φ(−|u|) = ½·e^(−u²/2)·erfcx(|u|/√2) with erfcx as a degree-7
/// polynomial in t = 1/(1 + 0.4·|u|/√2), Chebyshev-fitted on that range (this project's fit,
/// mpmath; fit error 3.7e−8): about half the work of the degree-12 fit for all u. With float
/// rounding |Φ error| < 3e−7, φ and Φ(u < 0) relative < 1.5e−6 (fast_math_test.cpp); past the
/// range the error grows.
inline constexpr float kNormalNearRange = 5.f;
template <class VF>
inline void normalCdfPdfNear(VF u, VF& cdf, VF& pdf) {
    const VF g = expNonPositive(u * u * -0.5f);
    const VF a = u < 0.f ? -u : u;
    const VF t = 1.f / (a * 0.28284271247461901f + 1.f);  // 0.4/√2
    VF q = splat<VF>(0.031648530206561247f);
    q = q * t - 0.37196966623084201f;
    q = q * t + 1.1028130683173461f;
    q = q * t - 0.86426043601289908f;
    q = q * t + 0.83230868619653456f;
    q = q * t + 0.0042439245790174815f;
    q = q * t + 0.26878192198263879f;
    q = q * t - 0.003566060126321572f;
    const VF tail = g * q * 0.5f;  // Φ(−|u|)
    cdf = u >= 0.f ? 1.f - tail : tail;
    pdf = g * static_cast<float>(kInvSqrt2Pi);
}

/// Sum of the lanes in double (pairwise: short dependency chains).
template <class V>
inline double sumLanes(V v) {
    constexpr int kW = sizeof(V) / sizeof(v[0]);
    double s[kW];
    for (int i = 0; i < kW; ++i) s[i] = static_cast<double>(v[i]);
    for (int w = kW / 2; w >= 1; w /= 2)
        for (int i = 0; i < w; ++i) s[i] += s[i + w];
    return s[0];
}

}  // namespace udvr::detail
