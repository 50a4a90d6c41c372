#pragma once
// Fast standard normal CDF Φ and density φ, sharing one exp().
// Φ(u) = ½·erfc(−u/√2), and for z ≥ 0 erfc(z) = t·e^(−z²)·Q(t) with t = 1/(1 + z/2), where Q is a
// degree-12 polynomial fitted (Chebyshev least squares on t ∈ (0, 1], this project's own fit) to
// erfcx(z)/t. Max |error| of erfc over z ≥ 0 is 7.2e−10, so |Φ error| < 4e−10; normal_cdf_test.cpp
// checks |error| < 1e−9 against std::erfc.
#include <cmath>
#include <type_traits>
#include <utility>

#include "udvr/util/check.h"

namespace udvr {

/// 1/√(2π): φ(0), the standard normal density's peak.
inline constexpr double kInvSqrt2Pi = 0.39894228040143267794;

/// φ(u) = e^(−u²/2)/√(2π), the standard normal density (normalAt gives it with Φ, sharing the
/// exp; this is φ alone).
UDVR_CPU_GPU inline double normalPdf(double u) { return std::exp(-0.5 * u * u) * kInvSqrt2Pi; }

/// Φ(u) and φ(u) of the standard normal distribution, and the upper tail 1 − Φ(u) computed as
/// such (no digits lost to 1 − Φ where Φ is near 1).
struct NormalCdfPdf {
    double cdf;
    double pdf;
    double upper;
};

namespace detail {
/// A value of T's scalar type: T itself, or the element type of a GCC vector type.
template <class T>
UDVR_CPU_GPU constexpr auto scalarOf() {
    if constexpr (std::is_arithmetic_v<T>)
        return T{};
    else
        return std::decay_t<decltype(std::declval<T&>()[0])>{};
}

/// erfc(z)·e^(z²) for z ≥ 0 (the scaled complementary error function erfcx), |rel. err| < 2e−9
/// in double (float lanes: float rounding, ~1e−7). T is double or a vector of doubles or floats
/// (util/fast_math.h and the batched ray loop evaluate it on lanes).
template <class T>
UDVR_CPU_GPU inline T erfcxNonNegative(T z) {
    using S = decltype(scalarOf<T>());  // double, or the lane type of a vector (float or double)
    const T t = S(1) / (S(1) + S(0.5) * z);
    T q = T{} - S(0.034835435706290684);  // T{} broadcasts for vectors
    q = q * t + S(0.20629037933280478);
    q = q * t - S(0.49051169818528501);
    q = q * t + S(0.55717139941080052);
    q = q * t - S(0.25002314249156715);
    q = q * t + S(0.0053214629887724484);
    q = q * t - S(0.057358821500754352);
    q = q * t - S(0.0079980889492288418);
    q = q * t + S(0.084723131459079976);
    q = q * t + S(0.17619189480161779);
    q = q * t + S(0.24683946872731444);
    q = q * t + S(0.28209465716430537);
    q = q * t + S(0.28209479222970868);
    return t * q;
}
}  // namespace detail

/// e^x by std::exp: normalAt's exponential on scalars (util/fast_math.h has the lanes' one).
struct StdExp {
    template <class T>
    UDVR_CPU_GPU T operator()(T x) const {
        return std::exp(x);
    }
};

/// Φ(u), the upper tail 1 − Φ(u), φ(u) = e^(−u²/2)/√(2π) and the mask u ≥ 0.
template <class T>
struct NormalAt {
    T cdf, upper, pdf;
    decltype(T{} >= T{}) nonNegative;
};

/// udvr's one standard normal CDF, over any real type T (double, float, or a GCC vector of
/// either): Φ(−|u|) = ½·e^(−u²/2)·erfcx(|u|/√2) with a single exp (`exp`: e^x for x ≤ 0 on T).
/// |Φ error| < 4e−10 in double, float rounding in float. The upper tail is computed as such,
/// never as 1 − Φ, so differences of upper tails keep their digits.
template <class T, class Exp = StdExp>
UDVR_CPU_GPU inline NormalAt<T> normalAt(T u, Exp exp = {}) {
    using S = decltype(detail::scalarOf<T>());
    const T g = exp(u * u * S(-0.5));  // e^(−z²) with z = |u|/√2
    const T a = u < S(0) ? -u : u;
    const T tail = S(0.5) * g * detail::erfcxNonNegative(a * S(0.70710678118654752440));
    const auto pos = u >= S(0);
    const T rest = S(1) - tail;
    return {pos ? rest : tail, pos ? tail : rest, S(kInvSqrt2Pi) * g, pos};
}

/// Φ(u) and φ(u) in double, |Φ error| < 1e−9 for all finite u.
UDVR_CPU_GPU inline NormalCdfPdf normalCdfPdf(double u) {
    const NormalAt<double> n = normalAt(u);
    return {n.cdf, n.pdf, n.upper};
}

/// Standard normal CDF Φ(u), |error| < 1e−9.
UDVR_CPU_GPU inline double normalCdf(double u) { return normalCdfPdf(u).cdf; }

/// erfc(x) for any finite x, |error| < 1e−9.
UDVR_CPU_GPU inline double fastErfc(double x) {
    const double e = std::exp(-x * x) * detail::erfcxNonNegative(std::fabs(x));
    return x >= 0.0 ? e : 2.0 - e;
}

/// erf(x) for any finite x, |error| < 1e−9.
UDVR_CPU_GPU inline double fastErf(double x) { return 1.0 - fastErfc(x); }

}  // namespace udvr
