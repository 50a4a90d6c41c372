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

/// In-place transpose of the 16×16 matrix whose row i is r[i] (unpacks within 128-bit blocks,
/// then block shuffles).
inline void transpose16(__m512 r[16]) {
    __m512 t[16], u[16];
    for (int i = 0; i < 16; i += 2) {
        t[i] = _mm512_unpacklo_ps(r[i], r[i + 1]);      // block k: r_i[4k], r_i+1[4k], … [4k+1]
        t[i + 1] = _mm512_unpackhi_ps(r[i], r[i + 1]);  // … [4k+2], [4k+3]
    }
    for (int i = 0; i < 16; i += 4)
        for (int h = 0; h < 2; ++h) {  // u[i + c]: element 4k + c of rows i … i+3 in block k
            const __m512d a = _mm512_castps_pd(t[i + h]), b = _mm512_castps_pd(t[i + 2 + h]);
            u[i + 2 * h] = _mm512_castpd_ps(_mm512_unpacklo_pd(a, b));
            u[i + 2 * h + 1] = _mm512_castpd_ps(_mm512_unpackhi_pd(a, b));
        }
    for (int c = 0; c < 4; ++c) {  // columns c, c+4, c+8, c+12 from u[c], u[4+c], u[8+c], u[12+c]
        const __m512 v0 = _mm512_shuffle_f32x4(u[c], u[4 + c], 0x88);
        const __m512 v1 = _mm512_shuffle_f32x4(u[8 + c], u[12 + c], 0x88);
        const __m512 w0 = _mm512_shuffle_f32x4(u[c], u[4 + c], 0xDD);
        const __m512 w1 = _mm512_shuffle_f32x4(u[8 + c], u[12 + c], 0xDD);
        r[c] = _mm512_shuffle_f32x4(v0, v1, 0x88);
        r[c + 8] = _mm512_shuffle_f32x4(v0, v1, 0xDD);
        r[c + 4] = _mm512_shuffle_f32x4(w0, w1, 0x88);
        r[c + 12] = _mm512_shuffle_f32x4(w0, w1, 0xDD);
    }
}

}  // namespace udvr::simd
#endif
