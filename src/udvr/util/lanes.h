#pragma once
// Portable lanes for the batched ray loop and the generic classification bodies.
//
// A batch is kWidth float lanes written with GCC vector extensions (`Vf`), kWidth the width of
// the target's vector register in floats: 16 on AVX-512, 8 on AVX2, 4 on SSE2 and NEON. (Vectors
// wider than the register compile badly: GCC 12 lowers a 16-float compare-and-select on AVX2 to
// about 100–350 scalar instructions, against 7 at the native width.) Masks are int32 lanes of −1
// (true) or 0 (`Mask`), the value of a vector comparison. Arithmetic, compares and selects are
// plain operators; only what the vector extensions cannot say is written per instruction set
// here, each with a portable fallback: gathers, small-table lookups (permutes), masked loads,
// FMA, square roots, mask bits, reductions and the kWidth×kWidth transpose.
//
// This header is the one place that defines vector types (`Vf`, `Vi`, `Vu`, and `Vec<E, W>` of
// any element and width: the per-voxel estimators' 8- and 16-lane vectors, util/fast_math.h's
// math runs over them) and the one place that calls intrinsics; scripts/check_layers.py fails on
// either anywhere else.
//
// The generic classification bodies (classify/, reconstruct/) take a value type T that is either
// a scalar (double for the exact path and probe, float for one GPU thread) or Vf; the overloads
// below give scalars the same vocabulary (select, anyOf, fma …), so one body serves all of them.
#include <bit>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <tuple>
#include <type_traits>
#include <utility>

#include "udvr/util/check.h"

#if defined(__AVX512F__) || defined(__AVX2__) || defined(__SSE2__)
// GCC 12's AVX-512 headers start many intrinsics from _mm512_undefined_ps(), which its
// -W(maybe-)uninitialized flag wherever they inline (GCC bug 105593, fixed in 13).
#pragma GCC diagnostic push
#if !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#pragma GCC diagnostic ignored "-Wuninitialized"
#include <immintrin.h>
#pragma GCC diagnostic pop
#endif
#if defined(__ARM_NEON) && defined(__aarch64__)
#include <arm_neon.h>
#endif

namespace udvr::lanes {

/// Lanes per batch: the target's vector register in floats.
#if defined(__AVX512F__)
inline constexpr int kWidth = 16;
#elif defined(__AVX__)
inline constexpr int kWidth = 8;
#else
inline constexpr int kWidth = 4;
#endif

using Vf = float __attribute__((vector_size(4 * kWidth)));          // kWidth floats
using Vi = std::int32_t __attribute__((vector_size(4 * kWidth)));   // kWidth int32, also masks
using Vu = std::uint32_t __attribute__((vector_size(4 * kWidth)));  // kWidth uint32 (bit tables)
using Mask = Vi;                                                    // lanes −1 (true) or 0

/// W lanes of E (float, int32, double, int64 …) for the code that is not the ray batch: the
/// per-voxel estimators of stats/ (EM, KDE sums: 8 or 16 lanes, two dependency chains per
/// operation on AVX2), double companions of a batch (Vec<double, kWidth>). Vec<float, kWidth> is
/// Vf.
template <class E, int W>
struct VectorOf {
    static_assert(W >= 1 && (W & (W - 1)) == 0, "a power-of-two lane count");
    // typedef, not using: GCC drops a value-dependent vector_size on an alias declaration.
    typedef E type __attribute__((vector_size(sizeof(E) * W)));
};
template <class E, int W>
using Vec = typename VectorOf<E, W>::type;
static_assert(std::is_same_v<Vec<float, kWidth>, Vf> && sizeof(Vec<double, 8>) == 64);
using V8f = Vec<float, 8>;
using V8i = Vec<std::int32_t, 8>;
using V8d = Vec<double, 8>;
using V8l = Vec<std::int64_t, 8>;

/// Bytes of the target's vector register.
#if defined(__AVX512F__)
inline constexpr std::size_t kRegisterBytes = 64;
#elif defined(__AVX__)
inline constexpr std::size_t kRegisterBytes = 32;
#else
inline constexpr std::size_t kRegisterBytes = 16;
#endif
/// Doubles of one vector register (8 on AVX-512, 4 on AVX2, 2 on SSE2/NEON).
using VRd = Vec<double, static_cast<int>(kRegisterBytes / sizeof(double))>;

/// Whether T is a lane vector (else a scalar).
template <class T>
inline constexpr bool kIsVector = std::is_same_v<T, Vf>;
/// Whether T is any GCC vector (Vf, or any Vec<E, W>).
template <class T>
concept AnyVector = !std::is_arithmetic_v<T> && requires(T v) {
    { v[0] + 0 } -> std::convertible_to<double>;
};
template <class T>
struct ElementOf {
    using type = T;
};
template <AnyVector T>
struct ElementOf<T> {
    using type = std::remove_cvref_t<decltype(std::declval<T>()[0])>;
};

/// The mask and integer types that go with a value type: bool and int for scalars.
template <class T>
using MaskOf = std::conditional_t<kIsVector<T>, Mask, bool>;
template <class T>
using IntOf = std::conditional_t<kIsVector<T>, Vi, int>;
/// The scalar type of T (float for Vf, the element type of any vector, T for a scalar).
template <class T>
using ScalarOf = typename ElementOf<T>::type;

// ---- construction --------------------------------------------------------------------------
/// Every lane = s (scalars: s itself); T is Vf, a scalar, or any Vec<E, W>. Written s − 0: that
/// is s in every lane, −0 included, so the compiler broadcasts s as it is (from memory, or as
/// an FMA's broadcast operand, where s is loaded); 0 + s would turn −0 into +0, and GCC then
/// adds before it broadcasts (a scalar add and a register broadcast per splat).
template <class T>
UDVR_CPU_GPU inline T splat(ScalarOf<T> s) {
    if constexpr (AnyVector<T>)
        return s - T{};
    else
        return s;
}
inline Vi splati(std::int32_t s) { return Vi{} + s; }
/// Lane i = i.
inline Vi iota() {
    return []<int... I>(std::integer_sequence<int, I...>) { return Vi{I...}; }
    (std::make_integer_sequence<int, kWidth>{});
}
inline Vf load(const float* p) {
    Vf v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
inline Vi load(const std::int32_t* p) {
    Vi v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
inline void store(float* p, Vf v) { std::memcpy(p, &v, sizeof v); }
inline void store(std::int32_t* p, Vi v) { std::memcpy(p, &v, sizeof v); }

// ---- masks ----------------------------------------------------------------------------------
/// Bit i = lane i of m.
inline std::uint32_t bits(Mask m) {
#if defined(__AVX512F__)
    const __mmask16 k = _mm512_cmplt_epi32_mask(std::bit_cast<__m512i>(m), _mm512_setzero_si512());
#if defined(__GNUC__) && !defined(__clang__)
    // GCC 12 -O3 wrong code: it may keep the widened value in a stack slot written by a 16-bit
    // `kmovw %k, mem` and read back 32 bits wide (`tzcnt`/`blsr mem`), so bits 16–31 are stale
    // stack bytes (seen: Bivariate2DKernel's members lanes iterated lanes 16–31 in
    // inDoublePerLane). An opaque 32-bit register move (kmovw zero-extends) keeps it a u32.
    std::uint32_t b;
    asm("kmovw %1, %0" : "=r"(b) : "k"(k));
    return b;
#else
    return k;
#endif
#elif defined(__AVX__)
    return static_cast<std::uint32_t>(_mm256_movemask_ps(std::bit_cast<__m256>(m)));
#elif defined(__SSE2__)
    return static_cast<std::uint32_t>(_mm_movemask_ps(std::bit_cast<__m128>(m)));
#else
    std::uint32_t b = 0;
    for (int i = 0; i < kWidth; ++i) b |= (m[i] < 0 ? 1u : 0u) << i;
    return b;
#endif
}
/// All kWidth bits set.
inline constexpr std::uint32_t kAllBits = (1u << kWidth) - 1u;
/// Lane i = bit i of b.
inline Mask fromBits(std::uint32_t b) {
    return ((splati(static_cast<std::int32_t>(b)) >> iota()) & 1) != 0;
}
/// Lanes i < n.
inline Mask firstLanes(int n) { return iota() < n; }
UDVR_CPU_GPU inline bool anyOf(bool m) { return m; }
inline bool anyOf(Mask m) { return bits(m) != 0; }
UDVR_CPU_GPU inline bool noneOf(bool m) { return !m; }
inline bool noneOf(Mask m) { return bits(m) == 0; }
UDVR_CPU_GPU inline bool allOf(bool m) { return m; }
inline bool allOf(Mask m) { return bits(m) == kAllBits; }
/// The constant true mask of T.
template <class T>
UDVR_CPU_GPU inline MaskOf<T> allTrue() {
    if constexpr (kIsVector<T>)
        return Vi{} == 0;
    else
        return true;
}

// ---- selection and arithmetic ---------------------------------------------------------------
/// m ? a : b lane by lane.
template <class T>
UDVR_CPU_GPU inline T select(bool m, T a, T b) {
    return m ? a : b;
}
inline Vf select(Mask m, Vf a, Vf b) { return m ? a : b; }
inline Vi select(Mask m, Vi a, Vi b) { return m ? a : b; }

/// a < b lane by lane for any Vec (the mask of a vector comparison: all ones or 0; false for
/// NaN), compared a register at a time. GCC 12 lowers comparisons of vectors wider than a
/// register (16 doubles on AVX-512) into one scalar compare and branch per lane; on the GMM's
/// 16-double parameters this made the per-iteration work cost more than a 20-sample E-step.
template <class V>
inline auto less(V a, V b) {
    using M = decltype(a < b);
    if constexpr (sizeof(V) <= kRegisterBytes) {
        return a < b;
    } else {
        using E = ScalarOf<V>;
        using H = Vec<E, static_cast<int>(sizeof(V) / sizeof(E) / 2)>;
        H a2[2], b2[2];
        std::memcpy(a2, &a, sizeof a);
        std::memcpy(b2, &b, sizeof b);
        const auto lo = less(a2[0], b2[0]);
        const auto hi = less(a2[1], b2[1]);
        M m;
        std::memcpy(&m, &lo, sizeof lo);
        std::memcpy(reinterpret_cast<char*>(&m) + sizeof lo, &hi, sizeof hi);
        return m;
    }
}

/// mask ? a : b lane by lane for any Vec and a comparison mask. Vectors wider than a register
/// take bit operations (as for less, GCC 12 lowers their ?: lane by lane); a register-wide one
/// keeps ?: (a blend under a mask register on AVX-512: the bit operations cost the EM 30 % there).
template <class V, class M>
inline V selectBits(M mask, V a, V b) {
    static_assert(sizeof(V) == sizeof(M));
    if constexpr (sizeof(V) <= kRegisterBytes)
        return mask ? a : b;
    else
        return std::bit_cast<V>((std::bit_cast<M>(a) & mask) | (std::bit_cast<M>(b) & ~mask));
}

/// a·b + c: one rounding where the target has FMA, two otherwise (scalars: always two, the
/// exact double path's arithmetic).
UDVR_CPU_GPU inline double fma(double a, double b, double c) { return a * b + c; }
UDVR_CPU_GPU inline float fma(float a, float b, float c) { return a * b + c; }
inline Vf fma(Vf a, Vf b, Vf c) {
#if defined(__AVX512F__)
    return _mm512_fmadd_ps(a, b, c);
#elif defined(__FMA__)
    return _mm256_fmadd_ps(a, b, c);
#elif defined(__ARM_FEATURE_FMA) && defined(__aarch64__)
    return vfmaq_f32(c, a, b);
#else
    return a * b + c;
#endif
}
UDVR_CPU_GPU inline double sqrt(double x) { return std::sqrt(x); }
UDVR_CPU_GPU inline float sqrt(float x) { return std::sqrt(x); }
inline Vf sqrt(Vf x) {
#if defined(__AVX512F__)
    return _mm512_sqrt_ps(x);
#elif defined(__AVX__)
    return _mm256_sqrt_ps(x);
#elif defined(__SSE2__)
    return _mm_sqrt_ps(x);
#elif defined(__ARM_NEON) && defined(__aarch64__)
    return vsqrtq_f32(x);
#else
    Vf r;
    for (int i = 0; i < kWidth; ++i) r[i] = std::sqrt(x[i]);
    return r;
#endif
}
/// Square root, floor and ceiling of 8 double lanes (the 2D gaussian's row setups,
/// classify/expected_tf2_fast.cpp): each lane as std::sqrt, std::floor, std::ceil give it.
inline V8d sqrt(V8d x) {
#if defined(__AVX512F__)
    return _mm512_sqrt_pd(x);
#elif defined(__AVX__)
    __m256d h[2];
    std::memcpy(h, &x, sizeof x);
    h[0] = _mm256_sqrt_pd(h[0]), h[1] = _mm256_sqrt_pd(h[1]);
    std::memcpy(&x, h, sizeof x);
    return x;
#else
    for (int i = 0; i < 8; ++i) x[i] = std::sqrt(x[i]);
    return x;
#endif
}
namespace detail {
/// x rounded to an integer toward −∞ (Up false) or +∞ (Up true), lane by lane.
template <bool Up>
inline V8d roundToward(V8d x) {
#if defined(__AVX512F__)
    return _mm512_roundscale_pd(
        x, (Up ? _MM_FROUND_TO_POS_INF : _MM_FROUND_TO_NEG_INF) | _MM_FROUND_NO_EXC);
#elif defined(__AVX__)
    __m256d h[2];
    std::memcpy(h, &x, sizeof x);
    for (__m256d& v : h)
        v = Up ? _mm256_round_pd(v, _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC)
               : _mm256_round_pd(v, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
    std::memcpy(&x, h, sizeof x);
    return x;
#else
    for (int i = 0; i < 8; ++i) x[i] = Up ? std::ceil(x[i]) : std::floor(x[i]);
    return x;
#endif
}
}  // namespace detail
inline V8d floor(V8d x) { return detail::roundToward<false>(x); }
inline V8d ceil(V8d x) { return detail::roundToward<true>(x); }
/// Int of a double truncated toward 0, lane by lane (lanes in range).
inline V8i truncToInt(V8d v) { return __builtin_convertvector(v, V8i); }
/// Float of a double, lane by lane (rounded to nearest, as static_cast<float>).
inline V8f toFloat(V8d v) { return __builtin_convertvector(v, V8f); }
template <class T>
UDVR_CPU_GPU inline T min(T a, T b) {
    return b < a ? b : a;
}
template <class T>
UDVR_CPU_GPU inline T max(T a, T b) {
    return a < b ? b : a;
}
UDVR_CPU_GPU inline double abs(double x) { return std::fabs(x); }
UDVR_CPU_GPU inline float abs(float x) { return std::fabs(x); }
inline Vf abs(Vf x) { return std::bit_cast<Vf>(std::bit_cast<Vi>(x) & 0x7FFFFFFF); }
/// Float of an int, int of a float truncated toward 0 (lanes in range).
inline Vf toFloat(Vi v) { return __builtin_convertvector(v, Vf); }
inline Vi truncToInt(Vf v) { return __builtin_convertvector(v, Vi); }
/// Smallest and largest lane of v among the `live` lanes (live must not be empty).
inline int minOf(Vi v, Mask live) {
#if defined(__AVX512F__)
    return _mm512_mask_reduce_min_epi32(static_cast<__mmask16>(bits(live)),
                                        std::bit_cast<__m512i>(v));
#else
    const Vi w = select(live, v, splati(0x7FFFFFFF));
    int m = w[0];
    for (int i = 1; i < kWidth; ++i) m = w[i] < m ? w[i] : m;
    return m;
#endif
}
inline int maxOf(Vi v, Mask live) {
#if defined(__AVX512F__)
    return _mm512_mask_reduce_max_epi32(static_cast<__mmask16>(bits(live)),
                                        std::bit_cast<__m512i>(v));
#else
    const Vi w = select(live, v, splati(-0x7FFFFFFF - 1));
    int m = w[0];
    for (int i = 1; i < kWidth; ++i) m = w[i] > m ? w[i] : m;
    return m;
#endif
}
/// Smallest and largest lane of v among the `live` lanes (live must not be empty; NaN lanes
/// may or may not win).
inline float minOf(Vf v, Mask live) {
    const Vf w = select(live, v, splat<Vf>(__builtin_inff()));
#if defined(__AVX512F__)
    return _mm512_reduce_min_ps(w);
#elif defined(__AVX__)
    __m256 m = _mm256_min_ps(w, _mm256_permute2f128_ps(w, w, 1));
    m = _mm256_min_ps(m, _mm256_permute_ps(m, 0x4E));
    m = _mm256_min_ps(m, _mm256_permute_ps(m, 0xB1));
    return _mm256_cvtss_f32(m);
#else
    float m = w[0];
    for (int i = 1; i < kWidth; ++i) m = w[i] < m ? w[i] : m;
    return m;
#endif
}
inline float maxOf(Vf v, Mask live) { return -minOf(-v, live); }
/// Sum of the lanes (pairwise: log2(kWidth) dependent adds).
inline float sum(Vf v) {
#if defined(__AVX512F__)
    return _mm512_reduce_add_ps(v);
#else
    float a[kWidth];
    std::memcpy(a, &v, sizeof v);
    for (int w = kWidth / 2; w >= 1; w /= 2)
        for (int i = 0; i < w; ++i) a[i] += a[i + w];
    return a[0];
#endif
}

// ---- lane movement (permutes) ---------------------------------------------------------------
// The permutes name their lanes as compile-time index lists (`__builtin_shufflevector`, which
// GCC ≥ 12 and Clang both have; index j ≥ kWidth picks lane j − kWidth of the second operand).
namespace detail {
template <int K, int... I>
inline Vf shiftUp(Vf v, Vf fill, std::integer_sequence<int, I...>) {
    return __builtin_shufflevector(v, fill, (I >= K ? I - K : I + kWidth)...);
}
template <int... I>
inline Vf shiftDown1(Vf v, Vf fill, std::integer_sequence<int, I...>) {
    return __builtin_shufflevector(v, fill, (I + 1)...);
}
}  // namespace detail
/// Lane i ← v[i − K] for i ≥ K, fill[i] below (0 < K < kWidth).
template <int K>
inline Vf shiftUp(Vf v, Vf fill) {
    static_assert(K >= 1 && K < kWidth);
    return detail::shiftUp<K>(v, fill, std::make_integer_sequence<int, kWidth>{});
}
/// Lane i ← v[i + 1] for i < kWidth − 1, fill[0] in the last lane.
inline Vf shiftDown1(Vf v, Vf fill) {
    return detail::shiftDown1(v, fill, std::make_integer_sequence<int, kWidth>{});
}
/// Inclusive prefix products: lane i ← v[0]·v[1]·…·v[i] (Hillis–Steele, log2(kWidth) steps).
inline Vf prefixProduct(Vf v) {
    const Vf one = splat<Vf>(1.f);
    v = v * shiftUp<1>(v, one);
    v = v * shiftUp<2>(v, one);
    if constexpr (kWidth > 4) v = v * shiftUp<4>(v, one);
    if constexpr (kWidth > 8) v = v * shiftUp<8>(v, one);
    return v;
}

/// Table sizes for which lookup<Size> is made of register permutes (the kernels pick the
/// smallest that holds a TF; other tables gather): AVX-512 one permute of 32 entries, AVX2 two
/// (16 entries) or four (32) 8-entry permutes and a blend tree.
#if defined(__AVX512F__)
inline constexpr int kPermuteSizes[] = {16, 32};
#elif defined(__AVX2__)
inline constexpr int kPermuteSizes[] = {16, 32};
#else
inline constexpr int kPermuteSizes[] = {0};
#endif

/// Whether an 8-entry lookup is one register permute where a 16- or 32-entry one takes two or
/// four and a blend tree (AVX2): kernels then look pieces up in a window of 8 consecutive
/// pieces where every lane's pieces fit in one (TfPieces::window). On AVX-512 a 16- or 32-entry
/// lookup is already one permute; elsewhere lookups are scalar loops.
#if defined(__AVX2__) && !defined(__AVX512F__)
inline constexpr bool kWindowLookups = true;
#else
inline constexpr bool kWindowLookups = false;
#endif

/// table[idx] per lane, idx in [0, Size) for Size ∈ {8, 16, 32} (a table of at least Size
/// floats; register permutes where the target has them), or any index into any table for
/// Size = 0 (a gather). The size is a template argument so the choice costs nothing in a loop.
template <int Size>
UDVR_INLINE Vf lookup(const float* table, Vi idx) {
    static_assert(Size == 0 || Size == 8 || Size == 16 || Size == 32);
#if defined(__AVX512F__)
    if constexpr (Size == 32)
        return _mm512_permutex2var_ps(_mm512_loadu_ps(table), std::bit_cast<__m512i>(idx),
                                      _mm512_loadu_ps(table + 16));
    else if constexpr (Size != 0)
        return _mm512_permutexvar_ps(std::bit_cast<__m512i>(idx), _mm512_loadu_ps(table));
    else
        return _mm512_i32gather_ps(std::bit_cast<__m512i>(idx), table, 4);
#elif defined(__AVX2__)
    const __m256i i = std::bit_cast<__m256i>(idx);
    if constexpr (Size != 0) {
        // 8-entry permutes, picked by bits 3 and 4 of the index (blendv reads the sign bit, so
        // each bit is shifted up to it).
        const auto permute = [&](int k) {
            return _mm256_permutevar8x32_ps(_mm256_loadu_ps(table + 8 * k), i);
        };
        if constexpr (Size == 8) return permute(0);
        const __m256 bit3 = _mm256_castsi256_ps(_mm256_slli_epi32(i, 28));
        const __m256 low = _mm256_blendv_ps(permute(0), permute(1), bit3);
        if constexpr (Size == 16) return low;
        const __m256 high = _mm256_blendv_ps(permute(2), permute(3), bit3);
        return _mm256_blendv_ps(low, high, _mm256_castsi256_ps(_mm256_slli_epi32(i, 27)));
    } else {
        return _mm256_i32gather_ps(table, i, 4);
    }
#else
    Vf r;
    for (int l = 0; l < kWidth; ++l) r[l] = table[idx[l]];
    return r;
#endif
}

// ---- memory ---------------------------------------------------------------------------------
/// base[idx] in the `live` lanes, 0 elsewhere (dead lanes' indices are not read).
inline Vf gather(const float* base, Vi idx, Mask live) {
#if defined(__AVX512F__)
    return _mm512_mask_i32gather_ps(_mm512_setzero_ps(), static_cast<__mmask16>(bits(live)),
                                    std::bit_cast<__m512i>(idx), base, 4);
#elif defined(__AVX2__)
    return _mm256_mask_i32gather_ps(_mm256_setzero_ps(), base, std::bit_cast<__m256i>(idx),
                                    std::bit_cast<__m256>(live), 4);
#else
    Vf r{};
    for (int l = 0; l < kWidth; ++l)
        if (live[l]) r[l] = base[idx[l]];
    return r;
#endif
}
/// base[idx] and base[idx + 1] in the `live` lanes (0 elsewhere): the two ends of an x-edge.
/// One 64-bit gather loads both: 16 edges take two 8-lane gathers on AVX-512, 8 edges two
/// 4-lane gathers on AVX2.
inline void gatherPair(const float* base, Vi idx, Mask live, Vf& v0, Vf& v1) {
#if defined(__AVX512F__)
    const std::uint32_t m = bits(live);
    const __m512i i = std::bit_cast<__m512i>(idx);
    const __m512 lo = _mm512_castpd_ps(_mm512_mask_i32gather_pd(
        _mm512_setzero_pd(), static_cast<__mmask8>(m & 0xFF), _mm512_castsi512_si256(i), base, 4));
    const __m512 hi = _mm512_castpd_ps(
        _mm512_mask_i32gather_pd(_mm512_setzero_pd(), static_cast<__mmask8>(m >> 8),
                                 _mm512_extracti64x4_epi64(i, 1), base, 4));
    v0 = __builtin_shufflevector(Vf(lo), Vf(hi), 0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26,
                                 28, 30);
    v1 = __builtin_shufflevector(Vf(lo), Vf(hi), 1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27,
                                 29, 31);
#elif defined(__AVX2__)
    // Two 4-lane 64-bit gathers (8 element loads instead of 16), then split even/odd floats.
    const __m256i i = std::bit_cast<__m256i>(idx);
    const __m256i m = std::bit_cast<__m256i>(live);
    const __m256d lo = _mm256_mask_i32gather_pd(
        _mm256_setzero_pd(), reinterpret_cast<const double*>(base), _mm256_castsi256_si128(i),
        _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm256_castsi256_si128(m))), 4);
    const __m256d hi = _mm256_mask_i32gather_pd(
        _mm256_setzero_pd(), reinterpret_cast<const double*>(base), _mm256_extracti128_si256(i, 1),
        _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm256_extracti128_si256(m, 1))), 4);
    v0 = __builtin_shufflevector(Vf(_mm256_castpd_ps(lo)), Vf(_mm256_castpd_ps(hi)), 0, 2, 4, 6, 8,
                                 10, 12, 14);
    v1 = __builtin_shufflevector(Vf(_mm256_castpd_ps(lo)), Vf(_mm256_castpd_ps(hi)), 1, 3, 5, 7, 9,
                                 11, 13, 15);
#else
    v0 = gather(base, idx, live);
    v1 = gather(base, idx + 1, live);
#endif
}
/// p[0 … n−1] in lanes 0 … n−1 (n ≤ kWidth), 0 above; reads nothing past p[n − 1].
inline Vf loadFirst(const float* p, int n) {
#if defined(__AVX512F__)
    return _mm512_maskz_loadu_ps(static_cast<__mmask16>((1u << n) - 1u), p);
#elif defined(__AVX__)
    return _mm256_maskload_ps(p, std::bit_cast<__m256i>(firstLanes(n)));
#else
    Vf r{};
    for (int i = 0; i < n; ++i) r[i] = p[i];
    return r;
#endif
}
#if defined(__AVX512F__)
namespace detail {
/// (a, b): a in floats 0 … 7, b in floats 8 … 15.
UDVR_INLINE Vf joinHalves(__m256 a, __m256 b) {
    return _mm512_castpd_ps(
        _mm512_insertf64x4(_mm512_castpd256_pd512(_mm256_castps_pd(a)), _mm256_castps_pd(b), 1));
}
}  // namespace detail
#endif
/// lo[0 … kWidth/2 − 1] in lanes 0 … kWidth/2 − 1 and hi[0 … kWidth/2 − 1] in the lanes above:
/// two short rows of memory in one register (AVX-512: two 256-bit loads and an insert; AVX: two
/// 128-bit ones; elsewhere two copies).
UDVR_INLINE Vf loadHalves(const float* lo, const float* hi) {
#if defined(__AVX512F__)
    return detail::joinHalves(_mm256_loadu_ps(lo), _mm256_loadu_ps(hi));
#elif defined(__AVX__)
    return _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(lo)), _mm_loadu_ps(hi), 1);
#else
    Vf v;
    std::memcpy(&v, lo, sizeof v / 2);
    std::memcpy(reinterpret_cast<char*>(&v) + sizeof v / 2, hi, sizeof v / 2);
    return v;
#endif
}
/// Packs the lanes of v in m to the front of dst and returns how many there are (kWidth floats
/// are written; those past the count are unspecified), so that work on a few lanes of many
/// batches runs on full vectors (classify/expected_tf.h, the fast box spline). Without AVX-512
/// nothing is packed: v is stored whole and kWidth returned; expandLoad reads either back.
inline int compressStore(float* dst, Vf v, Mask m) {
#if defined(__AVX512F__)
    // The register form and a plain store: with the memory form of vcompressps (microcoded on
    // AMD Zen 4) the fast box spline took twice as long.
    const auto k = static_cast<__mmask16>(bits(m));
    _mm512_storeu_ps(dst, _mm512_maskz_compress_ps(k, v));
    return std::popcount(static_cast<unsigned>(k));
#else
    static_cast<void>(m);
    store(dst, v);
    return kWidth;
#endif
}
/// The inverse of compressStore: the values packed at src back in the lanes of m (in order),
/// fallback in the others.
inline Vf expandLoad(const float* src, Mask m, Vf fallback) {
#if defined(__AVX512F__)
    return _mm512_mask_expand_ps(fallback, static_cast<__mmask16>(bits(m)), _mm512_loadu_ps(src));
#else
    return select(m, load(src), fallback);
#endif
}
/// src[0], src[1], … in the lanes of m in order (the k-th lane of m takes src[k]; reads
/// src[0 … kWidth − 1]), fallback in the others: items handed out in order to the lanes that
/// want one (classify/expected_tf2.h's segment pool). On every target, unlike expandLoad.
inline Vf expandFirst(const float* src, Mask m, Vf fallback) {
#if defined(__AVX512F__)
    return _mm512_mask_expand_ps(fallback, static_cast<__mmask16>(bits(m)), _mm512_loadu_ps(src));
#else
    Vf r = fallback;
    int k = 0;
    for (int l = 0; l < kWidth; ++l)
        if (m[l]) r[l] = src[k++];
    return r;
#endif
}
/// Bit v of a bit table per lane (`live` lanes; false elsewhere).
inline Mask testBits(const std::uint32_t* table, Vi v, Mask live) {
#if defined(__AVX512F__)
    const __m512i words =
        _mm512_mask_i32gather_epi32(_mm512_setzero_si512(), static_cast<__mmask16>(bits(live)),
                                    std::bit_cast<__m512i>(v >> 5), table, 4);
    return live & (((std::bit_cast<Vi>(words) >> (v & 31)) & 1) != 0);
#elif defined(__AVX2__)
    const __m256i words = _mm256_mask_i32gather_epi32(
        _mm256_setzero_si256(), reinterpret_cast<const int*>(table), std::bit_cast<__m256i>(v >> 5),
        std::bit_cast<__m256i>(live), 4);
    return live & (((std::bit_cast<Vu>(words) >> std::bit_cast<Vu>(v & 31)) & 1u) != 0u);
#else
    Vu words{};
    for (int l = 0; l < kWidth; ++l)
        if (live[l]) words[l] = table[v[l] >> 5];
    return live & (((words >> std::bit_cast<Vu>(v & 31)) & 1u) != 0u);
#endif
}

namespace detail {
/// The two in-lane stages of a register transpose of n rows r: t[i], t[i + 1] = the 32-bit
/// interleaves lo32/hi32 of rows i, i + 1; then u = the 64-bit interleaves lo64/hi64 of t[i + h]
/// and t[i + 2 + h] for each group of four rows.
template <int N, class V, class R, class Lo32, class Hi32, class Lo64, class Hi64>
UDVR_INLINE void interleaveStages(const R* r, V* t, V* u, Lo32 lo32, Hi32 hi32, Lo64 lo64,
                                  Hi64 hi64) {
    for (int i = 0; i < N; i += 2) {
        t[i] = lo32(r[i], r[i + 1]);
        t[i + 1] = hi32(r[i], r[i + 1]);
    }
    for (int i = 0; i < N; i += 4)
        for (int h = 0; h < 2; ++h) {
            u[i + 2 * h] = lo64(t[i + h], t[i + 2 + h]);
            u[i + 2 * h + 1] = hi64(t[i + h], t[i + 2 + h]);
        }
}
}  // namespace detail

/// In-place transpose of the kWidth×kWidth matrix whose row i is r[i].
inline void transpose(Vf r[kWidth]) {
#if defined(__AVX512F__)
    __m512 t[16], u[16];
    detail::interleaveStages<16>(
        r, t, u, [](__m512 a, __m512 b) { return _mm512_unpacklo_ps(a, b); },
        [](__m512 a, __m512 b) { return _mm512_unpackhi_ps(a, b); },
        [](__m512 a, __m512 b) {
            return _mm512_castpd_ps(_mm512_unpacklo_pd(_mm512_castps_pd(a), _mm512_castps_pd(b)));
        },
        [](__m512 a, __m512 b) {
            return _mm512_castpd_ps(_mm512_unpackhi_pd(_mm512_castps_pd(a), _mm512_castps_pd(b)));
        });
    for (int c = 0; c < 4; ++c) {
        const __m512 v0 = _mm512_shuffle_f32x4(u[c], u[4 + c], 0x88);
        const __m512 v1 = _mm512_shuffle_f32x4(u[8 + c], u[12 + c], 0x88);
        const __m512 w0 = _mm512_shuffle_f32x4(u[c], u[4 + c], 0xDD);
        const __m512 w1 = _mm512_shuffle_f32x4(u[8 + c], u[12 + c], 0xDD);
        r[c] = _mm512_shuffle_f32x4(v0, v1, 0x88);
        r[c + 8] = _mm512_shuffle_f32x4(v0, v1, 0xDD);
        r[c + 4] = _mm512_shuffle_f32x4(w0, w1, 0x88);
        r[c + 12] = _mm512_shuffle_f32x4(w0, w1, 0xDD);
    }
#elif defined(__AVX2__)
    // In-lane unpacks and shuffles, then 128-bit halves across rows (24 single-cycle shuffles;
    // the generic rounds below take two-source cross-lane permutes, 2 to 3 instructions each).
    __m256 t[8], u[8];
    detail::interleaveStages<8>(
        r, t, u, [](__m256 a, __m256 b) { return _mm256_unpacklo_ps(a, b); },
        [](__m256 a, __m256 b) { return _mm256_unpackhi_ps(a, b); },
        [](__m256 a, __m256 b) { return _mm256_shuffle_ps(a, b, 0x44); },
        [](__m256 a, __m256 b) { return _mm256_shuffle_ps(a, b, 0xEE); });
    for (int c = 0; c < 4; ++c) {
        r[c] = _mm256_permute2f128_ps(u[c], u[4 + c], 0x20);
        r[c + 4] = _mm256_permute2f128_ps(u[c], u[4 + c], 0x31);
    }
#else
    // log2(kWidth) rounds of interleaving row i with row i + kWidth/2 (a perfect shuffle of the
    // index bits (row, column): each round rotates them by one, so the rounds swap row and
    // column).
    // Lane j of the lower interleave is lane j/2 of row i (j even) or of row i + kWidth/2
    // (j odd); the upper one starts kWidth/2 lanes further on.
    constexpr int kHalf = kWidth / 2;
    const auto interleave = [&]<int... J>(Vf a, Vf b, std::integer_sequence<int, J...>) {
        return std::pair{
            __builtin_shufflevector(a, b, ((J >> 1) + ((J & 1) ? kWidth : 0))...),
            __builtin_shufflevector(a, b, ((J >> 1) + kHalf + ((J & 1) ? kWidth : 0))...)};
    };
    Vf t[kWidth];
    for (int round = 1; round < kWidth; round *= 2) {
        for (int i = 0; i < kHalf; ++i)
            std::tie(t[2 * i], t[2 * i + 1]) =
                interleave(r[i], r[i + kHalf], std::make_integer_sequence<int, kWidth>{});
        for (int i = 0; i < kWidth; ++i) r[i] = t[i];
    }
#endif
}

#if defined(__AVX512F__)
// ---- 16-lane shuffles by 128-bit block (AVX-512's four blocks of 4 floats) -------------------
/// (v_L × 8, v_{L+1} × 8): lane L's value in the low 256-bit half, lane L + 1's in the high one.
template <int L>
UDVR_INLINE Vf pairHalves(Vf v) {
    static_assert(L >= 0 && L + 1 < kWidth);
    return __builtin_shufflevector(v, v, L, L, L, L, L, L, L, L, L + 1, L + 1, L + 1, L + 1, L + 1,
                                   L + 1, L + 1, L + 1);
}
/// v's blocks (b₁, b₀, b₃, b₂): the two blocks of each 256-bit half swapped.
UDVR_INLINE Vf swapBlocksInHalves(Vf v) {
    return __builtin_shufflevector(v, v, 4, 5, 6, 7, 0, 1, 2, 3, 12, 13, 14, 15, 8, 9, 10, 11);
}
/// (a₀, a₂, b₀, b₂): the even blocks of a, then of b.
UDVR_INLINE Vf evenBlocks(Vf a, Vf b) {
    return __builtin_shufflevector(a, b, 0, 1, 2, 3, 8, 9, 10, 11, 16, 17, 18, 19, 24, 25, 26, 27);
}
/// (a₁, a₃, b₁, b₃): the odd blocks of a, then of b.
UDVR_INLINE Vf oddBlocks(Vf a, Vf b) {
    return __builtin_shufflevector(a, b, 4, 5, 6, 7, 12, 13, 14, 15, 20, 21, 22, 23, 28, 29, 30,
                                   31);
}

/// The 4×4 transpose within each 128-bit block of four registers: block j of out[k] holds
/// float k of block j of in[0], in[1], in[2], in[3] (unpacks, then 64-bit pair shuffles).
inline void transposeBlocks4(const Vf in[4], Vf out[4]) {
    const __m512 t0 = _mm512_unpacklo_ps(in[0], in[1]), t1 = _mm512_unpackhi_ps(in[0], in[1]);
    const __m512 t2 = _mm512_unpacklo_ps(in[2], in[3]), t3 = _mm512_unpackhi_ps(in[2], in[3]);
    out[0] = _mm512_shuffle_ps(t0, t2, 0x44);
    out[1] = _mm512_shuffle_ps(t0, t2, 0xEE);
    out[2] = _mm512_shuffle_ps(t1, t3, 0x44);
    out[3] = _mm512_shuffle_ps(t1, t3, 0xEE);
}
#endif

/// out[k] = base[idx + k] for k = 0 … 7 in the `live` lanes (0 elsewhere; dead lanes' indices
/// are not read): 8 adjacent floats a lane, as two RGBA points of a raster row. With AVX-512VL
/// or AVX2 each lane's 8 floats are one 256-bit load and an 8×8 transpose puts them in place
/// (16 lanes: 16 loads and 32 shuffles, against 8 64-bit gathers and 8 permutes for four
/// gatherPairs); elsewhere four gatherPairs. Always inlined: called out of line from the TF2
/// segment walk, its 8 results went through memory.
UDVR_INLINE void gatherRow8(const float* base, Vi idx, Mask live, Vf out[8]) {
#if defined(__AVX512F__) && defined(__AVX512VL__)
    const std::uint32_t m = bits(live);
    alignas(64) std::int32_t at[16];
    store(at, idx);
    Vf r[8], u[8];
    for (int l = 0; l < 8; ++l) {  // lane l in the low half, lane l + 8 in the high one
        const auto lo = static_cast<__mmask8>(0u - (m >> l & 1u));
        const auto hi = static_cast<__mmask8>(0u - (m >> (l + 8) & 1u));
        const __m256 a = _mm256_maskz_loadu_ps(lo, base + at[l]);
        const __m256 b = _mm256_maskz_loadu_ps(hi, base + at[l + 8]);
        r[l] = detail::joinHalves(a, b);
    }
    // The 8×8 transpose of AVX2 (transpose below) in both halves at once.
    transposeBlocks4(r, u);
    transposeBlocks4(r + 4, u + 4);
    for (int c = 0; c < 4; ++c) {  // 128-bit blocks: (u_c 0, u_{4+c} 0, u_c 2, u_{4+c} 2) …
        const Vf a = u[c], b = u[4 + c];
        out[c] =
            __builtin_shufflevector(a, b, 0, 1, 2, 3, 16, 17, 18, 19, 8, 9, 10, 11, 24, 25, 26, 27);
        out[c + 4] = __builtin_shufflevector(a, b, 4, 5, 6, 7, 20, 21, 22, 23, 12, 13, 14, 15, 28,
                                             29, 30, 31);
    }
#elif defined(__AVX2__) && !defined(__AVX512F__)
    alignas(32) std::int32_t at[8];
    store(at, idx);
    for (int l = 0; l < 8; ++l) {
        const __m256i lane = _mm256_set1_epi32(live[l]);
        out[l] = _mm256_maskload_ps(base + at[l], lane);
    }
    transpose(out);
#else
    for (int k = 0; k < 8; k += 2) gatherPair(base, idx + k, live, out[k], out[k + 1]);
#endif
}

}  // namespace udvr::lanes
