#pragma once
// AVX-512 helpers for the batched ray loop (16 float lanes); the transcendental functions are
// util/fast_math.h's, which take __m512 as they take any float vector. Everything here exists only
// when the compiler targets AVX-512F (UDVR_NATIVE on a machine that has it); callers keep a scalar
// path for other machines and test both (docs/building.md).
#if defined(__AVX512F__) && defined(__AVX512DQ__)
#define UDVR_HAVE_AVX512 1
// GCC 12's AVX-512 headers start many intrinsics from _mm512_undefined_ps(), which its
// -W(maybe-)uninitialized flag wherever they inline (GCC bug 105593, fixed in 13): silence
// them for the header's own lines only.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#include <immintrin.h>
#pragma GCC diagnostic pop

namespace udvr::simd {

/// Lanes of a __m512 of floats.
inline constexpr int kLanes = 16;

/// Lane i ← v[i − k] for i ≥ k, `fill` below (k in 1 … 15).
template <int K>
inline __m512 shiftUp(__m512 v, __m512 fill) {
    static_assert(K >= 1 && K <= 15);
    return _mm512_castsi512_ps(
        _mm512_alignr_epi32(_mm512_castps_si512(v), _mm512_castps_si512(fill), 16 - K));
}

/// Inclusive prefix products: lane i ← v[0]·v[1]·…·v[i] (Hillis–Steele, four steps).
inline __m512 prefixProduct(__m512 v) {
    const __m512 one = _mm512_set1_ps(1.f);
    v = _mm512_mul_ps(v, shiftUp<1>(v, one));
    v = _mm512_mul_ps(v, shiftUp<2>(v, one));
    v = _mm512_mul_ps(v, shiftUp<4>(v, one));
    v = _mm512_mul_ps(v, shiftUp<8>(v, one));
    return v;
}

/// Lane `i` of v.
inline float lane(__m512 v, int i) {
    return _mm512_cvtss_f32(_mm512_permutexvar_ps(_mm512_set1_epi32(i), v));
}

/// The sums of the 16 lanes of a, b, c and d, in out[0 … 3] (one shuffle tree for all four).
inline void sum4(__m512 a, __m512 b, __m512 c, __m512 d, float out[4]) {
    // 128-bit blocks: [a0+a2, a1+a3, b0+b2, b1+b3] and the same for c, d.
    const __m512 ab =
        _mm512_add_ps(_mm512_shuffle_f32x4(a, b, 0x44), _mm512_shuffle_f32x4(a, b, 0xEE));
    const __m512 cd =
        _mm512_add_ps(_mm512_shuffle_f32x4(c, d, 0x44), _mm512_shuffle_f32x4(c, d, 0xEE));
    // Blocks: [a, b, c, d] partial sums of 4 lanes each.
    const __m512 s =
        _mm512_add_ps(_mm512_shuffle_f32x4(ab, cd, 0x88), _mm512_shuffle_f32x4(ab, cd, 0xDD));
    // Within each block: lanes (0+2, 1+3), then (0+1).
    const __m512 t = _mm512_add_ps(s, _mm512_permute_ps(s, 0x4E));
    const __m512 u = _mm512_add_ps(t, _mm512_permute_ps(t, 0xB1));
    alignas(64) float lanes[16];
    _mm512_store_ps(lanes, u);
    out[0] = lanes[0];
    out[1] = lanes[4];
    out[2] = lanes[8];
    out[3] = lanes[12];
}

/// The sums of lanes 0–7 and of lanes 8–15 of a, b, c and d, in lo[0 … 3] and hi[0 … 3].
inline void sumHalves4(__m512 a, __m512 b, __m512 c, __m512 d, float lo[4], float hi[4]) {
    // 128-bit blocks: [a0+a1, a2+a3, b0+b1, b2+b3] (a's halves, then b's) and the same for c, d.
    const __m512 ab =
        _mm512_add_ps(_mm512_shuffle_f32x4(a, b, 0x88), _mm512_shuffle_f32x4(a, b, 0xDD));
    const __m512 cd =
        _mm512_add_ps(_mm512_shuffle_f32x4(c, d, 0x88), _mm512_shuffle_f32x4(c, d, 0xDD));
    const auto within = [](__m512 s) {  // lane 0 of each block ← the block's sum
        const __m512 t = _mm512_add_ps(s, _mm512_permute_ps(s, 0x4E));
        return _mm512_add_ps(t, _mm512_permute_ps(t, 0xB1));
    };
    alignas(64) float x[16], y[16];
    _mm512_store_ps(x, within(ab));
    _mm512_store_ps(y, within(cd));
    lo[0] = x[0];
    hi[0] = x[4];
    lo[1] = x[8];
    hi[1] = x[12];
    lo[2] = y[0];
    hi[2] = y[4];
    lo[3] = y[8];
    hi[3] = y[12];
}

}  // namespace udvr::simd
#endif
