#pragma once
// Portable lanes for the batched ray loop and the generic classification bodies.
//
// A batch is 16 float lanes written with GCC vector extensions (`Vf`, 64 bytes): the same source
// compiles to one AVX-512 register, two AVX2 registers, four SSE2 or NEON registers. Masks are
// int32 lanes of −1 (true) or 0 (`Mask`), the value of a vector comparison. Arithmetic, compares
// and selects are plain operators; only what the vector extensions cannot say is written per
// instruction set here, each with a portable fallback: gathers, small-table lookups (permutes),
// masked loads, FMA, square roots, mask reductions and the 16×16 transpose.
//
// The generic classification bodies (classify/, reconstruct/) take a value type T that is either
// a scalar (double for the exact path and probe, float for one GPU thread) or Vf; the overloads
// below give scalars the same vocabulary (select, anyOf, fma …), so one body serves all of them.
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <type_traits>

#include "udvr/util/check.h"

#if defined(__AVX512F__) || defined(__AVX2__)
#define UDVR_LANES_X86 1
// GCC 12's AVX-512 headers start many intrinsics from _mm512_undefined_ps(), which its
// -W(maybe-)uninitialized flag wherever they inline (GCC bug 105593, fixed in 13).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#include <immintrin.h>
#pragma GCC diagnostic pop
#endif

namespace udvr::lanes {

/// Lanes per batch on every target.
inline constexpr int kWidth = 16;

using Vf = float __attribute__((vector_size(64)));          // 16 floats
using Vi = std::int32_t __attribute__((vector_size(64)));   // 16 int32, also the mask type
using Vu = std::uint32_t __attribute__((vector_size(64)));  // 16 uint32 (bit tables)
using Mask = Vi;                                            // lanes −1 (true) or 0

/// Whether T is a lane vector (else a scalar).
template <class T>
inline constexpr bool kIsVector = std::is_same_v<T, Vf>;

/// The mask and integer types that go with a value type: bool and int for scalars.
template <class T>
using MaskOf = std::conditional_t<kIsVector<T>, Mask, bool>;
template <class T>
using IntOf = std::conditional_t<kIsVector<T>, Vi, int>;
/// The scalar type of T (float for Vf).
template <class T>
using ScalarOf = std::conditional_t<kIsVector<T>, float, T>;

#if defined(__AVX2__) && !defined(__AVX512F__)
/// The two 256-bit halves of a 16-lane vector, and back (AVX2: one batch is two registers).
inline __m256 lowHalf(Vf v) { return __builtin_shufflevector(v, v, 0, 1, 2, 3, 4, 5, 6, 7); }
inline __m256 highHalf(Vf v) { return __builtin_shufflevector(v, v, 8, 9, 10, 11, 12, 13, 14, 15); }
inline __m256i lowHalf(Vi v) {
    return std::bit_cast<__m256i>(__builtin_shufflevector(v, v, 0, 1, 2, 3, 4, 5, 6, 7));
}
inline __m256i highHalf(Vi v) {
    return std::bit_cast<__m256i>(__builtin_shufflevector(v, v, 8, 9, 10, 11, 12, 13, 14, 15));
}
inline Vf join(__m256 lo, __m256 hi) {
    return __builtin_shufflevector(lo, hi, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
}
inline Vi join(__m256i lo, __m256i hi) {
    using V8i = std::int32_t __attribute__((vector_size(32)));
    return __builtin_shufflevector(std::bit_cast<V8i>(lo), std::bit_cast<V8i>(hi), 0, 1, 2, 3, 4, 5,
                                   6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
}
#endif

// ---- construction --------------------------------------------------------------------------
/// Every lane = s (scalars: s itself).
template <class T>
UDVR_CPU_GPU inline T splat(ScalarOf<T> s) {
    if constexpr (kIsVector<T>)
        return Vf{} + s;
    else
        return s;
}
inline Vi splati(std::int32_t s) { return Vi{} + s; }
/// Lane i = i.
inline Vi iota() { return Vi{0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15}; }
inline Vf load(const float* p) {
    Vf v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
inline void store(float* p, Vf v) { std::memcpy(p, &v, sizeof v); }
inline void store(std::int32_t* p, Vi v) { std::memcpy(p, &v, sizeof v); }

// ---- masks ----------------------------------------------------------------------------------
/// Bit i = lane i of m.
inline std::uint32_t bits(Mask m) {
#if defined(__AVX512F__)
    return _mm512_cmplt_epi32_mask(std::bit_cast<__m512i>(m), _mm512_setzero_si512());
#elif defined(__AVX2__)
    const __m256i lo =
        std::bit_cast<__m256i>(__builtin_shufflevector(m, m, 0, 1, 2, 3, 4, 5, 6, 7));
    const __m256i hi =
        std::bit_cast<__m256i>(__builtin_shufflevector(m, m, 8, 9, 10, 11, 12, 13, 14, 15));
    return static_cast<std::uint32_t>(_mm256_movemask_ps(_mm256_castsi256_ps(lo))) |
           static_cast<std::uint32_t>(_mm256_movemask_ps(_mm256_castsi256_ps(hi))) << 8;
#else
    std::uint32_t b = 0;
    for (int i = 0; i < kWidth; ++i) b |= (m[i] < 0 ? 1u : 0u) << i;
    return b;
#endif
}
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
inline bool allOf(Mask m) { return bits(m) == 0xFFFFu; }
/// The constant true/false mask of T.
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

/// a·b + c: one rounding where the target has FMA, two otherwise (scalars: always two, the
/// exact double path's arithmetic).
UDVR_CPU_GPU inline double fma(double a, double b, double c) { return a * b + c; }
UDVR_CPU_GPU inline float fma(float a, float b, float c) { return a * b + c; }
inline Vf fma(Vf a, Vf b, Vf c) {
#if defined(__AVX512F__)
    return _mm512_fmadd_ps(a, b, c);
#elif defined(__FMA__)
    const __m256 lo = _mm256_fmadd_ps(__builtin_shufflevector(a, a, 0, 1, 2, 3, 4, 5, 6, 7),
                                      __builtin_shufflevector(b, b, 0, 1, 2, 3, 4, 5, 6, 7),
                                      __builtin_shufflevector(c, c, 0, 1, 2, 3, 4, 5, 6, 7));
    const __m256 hi = _mm256_fmadd_ps(__builtin_shufflevector(a, a, 8, 9, 10, 11, 12, 13, 14, 15),
                                      __builtin_shufflevector(b, b, 8, 9, 10, 11, 12, 13, 14, 15),
                                      __builtin_shufflevector(c, c, 8, 9, 10, 11, 12, 13, 14, 15));
    return __builtin_shufflevector(lo, hi, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
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
    const __m256 lo = _mm256_sqrt_ps(__builtin_shufflevector(x, x, 0, 1, 2, 3, 4, 5, 6, 7));
    const __m256 hi = _mm256_sqrt_ps(__builtin_shufflevector(x, x, 8, 9, 10, 11, 12, 13, 14, 15));
    return __builtin_shufflevector(lo, hi, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
#else
    Vf r;
    for (int i = 0; i < kWidth; ++i) r[i] = std::sqrt(x[i]);
    return r;
#endif
}
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
/// Smallest and largest lane of v among the `live` lanes (live must not be empty), by a
/// shuffle tree.
template <bool Largest>
inline int extremeOf(Vi v, Mask live) {
    const auto pick = [](auto a, auto b) { return Largest ? (a > b ? a : b) : (a < b ? a : b); };
    const Vi w = select(live, v, splati(Largest ? -0x7FFFFFFF - 1 : 0x7FFFFFFF));
    const auto a = pick(__builtin_shufflevector(w, w, 0, 1, 2, 3, 4, 5, 6, 7),
                        __builtin_shufflevector(w, w, 8, 9, 10, 11, 12, 13, 14, 15));
    const auto b =
        pick(__builtin_shufflevector(a, a, 0, 1, 2, 3), __builtin_shufflevector(a, a, 4, 5, 6, 7));
    const auto c = pick(__builtin_shufflevector(b, b, 0, 1), __builtin_shufflevector(b, b, 2, 3));
    return c[0] > c[1] ? (Largest ? c[0] : c[1]) : (Largest ? c[1] : c[0]);
}
inline int minOf(Vi v, Mask live) { return extremeOf<false>(v, live); }
inline int maxOf(Vi v, Mask live) { return extremeOf<true>(v, live); }
/// Sum of the lanes (pairwise).
inline float sum(Vf v) {
    const auto a = __builtin_shufflevector(v, v, 0, 1, 2, 3, 4, 5, 6, 7) +
                   __builtin_shufflevector(v, v, 8, 9, 10, 11, 12, 13, 14, 15);
    const auto b =
        __builtin_shufflevector(a, a, 0, 1, 2, 3) + __builtin_shufflevector(a, a, 4, 5, 6, 7);
    const auto c = __builtin_shufflevector(b, b, 0, 1) + __builtin_shufflevector(b, b, 2, 3);
    return c[0] + c[1];
}

// ---- lane movement (permutes) ---------------------------------------------------------------
/// Lane i ← v[i − K] for i ≥ K, fill[i] below (K in 1 … 15).
template <int K>
inline Vf shiftUp(Vf v, Vf fill) {
    static_assert(K >= 1 && K <= 15);
    const Vi idx = iota() >= K ? iota() - K : iota() + kWidth;
    return __builtin_shuffle(v, fill, idx);
}
/// Lane i ← v[i + 1] for i < 15, fill[15] in lane 15.
inline Vf shiftDown1(Vf v, Vf fill) {
    return __builtin_shufflevector(v, fill, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 31);
}
/// Inclusive prefix products: lane i ← v[0]·v[1]·…·v[i] (Hillis–Steele, four steps).
inline Vf prefixProduct(Vf v) {
    const Vf one = splat<Vf>(1.f);
    v = v * shiftUp<1>(v, one);
    v = v * shiftUp<2>(v, one);
    v = v * shiftUp<4>(v, one);
    v = v * shiftUp<8>(v, one);
    return v;
}

/// table[idx] per lane, idx in [0, size): with Size = 32 (a table of 32 floats) a register
/// permute on AVX-512; with Size = 0 a table of any size (a gather). The size is a template
/// argument so that the choice costs nothing in the loop.
template <int Size>
UDVR_INLINE Vf lookup(const float* table, Vi idx) {
#if defined(__AVX512F__)
    if constexpr (Size == 32)
        return _mm512_permutex2var_ps(_mm512_loadu_ps(table), std::bit_cast<__m512i>(idx),
                                      _mm512_loadu_ps(table + 16));
    else
        return _mm512_i32gather_ps(std::bit_cast<__m512i>(idx), table, 4);
#elif defined(__AVX2__)
    const auto half = [&](__m256i i) {
        if constexpr (Size == 32) {
            // Four in-register 8-entry permutes, picked by bits 3 and 4 of the index (blendv
            // reads the sign bit, so the bit is shifted up to it).
            const __m256 p0 = _mm256_permutevar8x32_ps(_mm256_loadu_ps(table), i);
            const __m256 p1 = _mm256_permutevar8x32_ps(_mm256_loadu_ps(table + 8), i);
            const __m256 p2 = _mm256_permutevar8x32_ps(_mm256_loadu_ps(table + 16), i);
            const __m256 p3 = _mm256_permutevar8x32_ps(_mm256_loadu_ps(table + 24), i);
            const __m256 bit3 = _mm256_castsi256_ps(_mm256_slli_epi32(i, 28));
            const __m256 bit4 = _mm256_castsi256_ps(_mm256_slli_epi32(i, 27));
            return _mm256_blendv_ps(_mm256_blendv_ps(p0, p1, bit3), _mm256_blendv_ps(p2, p3, bit3),
                                    bit4);
        } else {
            return _mm256_i32gather_ps(table, i, 4);
        }
    };
    return join(half(lowHalf(idx)), half(highHalf(idx)));
#else
    Vf r;
    for (int i = 0; i < kWidth; ++i) r[i] = table[idx[i]];
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
    const auto half = [&](__m256i i, __m256i m) {
        return _mm256_mask_i32gather_ps(_mm256_setzero_ps(), base, i, _mm256_castsi256_ps(m), 4);
    };
    return join(half(lowHalf(idx), lowHalf(live)), half(highHalf(idx), highHalf(live)));
#else
    Vf r{};
    for (int i = 0; i < kWidth; ++i)
        if (live[i]) r[i] = base[idx[i]];
    return r;
#endif
}
/// base[idx] and base[idx + 1] in the `live` lanes (0 elsewhere): the two ends of an x-edge.
/// On AVX-512 one 64-bit gather loads both, so 16 edges take two 8-lane gathers.
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
#else
    v0 = gather(base, idx, live);
    v1 = gather(base, idx + 1, live);
#endif
}
/// p[0 … n−1] in lanes 0 … n−1 (n ≤ 16), 0 above; reads nothing past p[n − 1].
inline Vf loadFirst(const float* p, int n) {
#if defined(__AVX512F__)
    return _mm512_maskz_loadu_ps(static_cast<__mmask16>((1u << n) - 1u), p);
#elif defined(__AVX2__)
    const Mask m = firstLanes(n);
    return join(_mm256_maskload_ps(p, lowHalf(m)), _mm256_maskload_ps(p + 8, highHalf(m)));
#else
    Vf r{};
    for (int i = 0; i < n; ++i) r[i] = p[i];
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
    const auto half = [&](__m256i i, __m256i m) {
        return _mm256_mask_i32gather_epi32(_mm256_setzero_si256(),
                                           reinterpret_cast<const int*>(table), i, m, 4);
    };
    const Vi words =
        join(half(lowHalf(v >> 5), lowHalf(live)), half(highHalf(v >> 5), highHalf(live)));
    return live & (((std::bit_cast<Vu>(words) >> std::bit_cast<Vu>(v & 31)) & 1u) != 0u);
#else
    Vi words{};
    for (int i = 0; i < kWidth; ++i)
        if (live[i]) words[i] = static_cast<std::int32_t>(table[v[i] >> 5]);
    return live & (((std::bit_cast<Vu>(words) >> std::bit_cast<Vu>(v & 31)) & 1u) != 0u);
#endif
}

/// In-place transpose of the 16×16 matrix whose row i is r[i].
inline void transpose16(Vf r[16]) {
#if defined(__AVX512F__)
    __m512 t[16], u[16];
    for (int i = 0; i < 16; i += 2) {
        t[i] = _mm512_unpacklo_ps(r[i], r[i + 1]);
        t[i + 1] = _mm512_unpackhi_ps(r[i], r[i + 1]);
    }
    for (int i = 0; i < 16; i += 4)
        for (int h = 0; h < 2; ++h) {
            const __m512d a = _mm512_castps_pd(t[i + h]), b = _mm512_castps_pd(t[i + 2 + h]);
            u[i + 2 * h] = _mm512_castpd_ps(_mm512_unpacklo_pd(a, b));
            u[i + 2 * h + 1] = _mm512_castpd_ps(_mm512_unpackhi_pd(a, b));
        }
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
#else
    // Four rounds of interleaving row i with row i + 8 (a perfect shuffle of the 8-bit index
    // (row, column): each round rotates it by one bit, so four rounds swap row and column).
    Vf t[16];
    for (int round = 0; round < 4; ++round) {
        for (int i = 0; i < 8; ++i) {
            t[2 * i] = __builtin_shufflevector(r[i], r[i + 8], 0, 16, 1, 17, 2, 18, 3, 19, 4, 20, 5,
                                               21, 6, 22, 7, 23);
            t[2 * i + 1] = __builtin_shufflevector(r[i], r[i + 8], 8, 24, 9, 25, 10, 26, 11, 27, 12,
                                                   28, 13, 29, 14, 30, 15, 31);
        }
        for (int i = 0; i < 16; ++i) r[i] = t[i];
    }
#endif
}

}  // namespace udvr::lanes
