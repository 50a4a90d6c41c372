#pragma once
// AVX-512 helpers for the batched ray loop (16 float lanes). Everything here exists only when
// the compiler targets AVX-512F (UDVR_NATIVE on a machine that has it); callers keep a scalar
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

/// ln((1 + s)/(1 − s)) = 2·atanh(s) for |s| ≤ 0.2, by its series to s⁹ (truncation < 4e−9).
inline __m512 logOfAtanhArg(__m512 s) {
    const __m512 s2 = _mm512_mul_ps(s, s);
    __m512 p = _mm512_set1_ps(1.f / 9.f);
    p = _mm512_fmadd_ps(p, s2, _mm512_set1_ps(1.f / 7.f));
    p = _mm512_fmadd_ps(p, s2, _mm512_set1_ps(1.f / 5.f));
    p = _mm512_fmadd_ps(p, s2, _mm512_set1_ps(1.f / 3.f));
    p = _mm512_fmadd_ps(p, s2, _mm512_set1_ps(1.f));
    return _mm512_mul_ps(_mm512_add_ps(s, s), p);
}

/// ln(x) for finite x > 0 (also subnormal): x = m·2^k with m ∈ [0.75, 1.5), then
/// ln m = 2·atanh(s), s = (m − 1)/(m + 1), |s| ≤ 0.2 (logOfAtanhArg). Relative error ≈ 1e−7
/// (float rounding).
inline __m512 logPs(__m512 x) {
    const __m512 one = _mm512_set1_ps(1.f);
    const __m512 m = _mm512_getmant_ps(x, _MM_MANT_NORM_p75_1p5, _MM_MANT_SIGN_src);
    // getexp gives ⌊log2 x⌋ for the [1, 2) mantissa; a mantissa below 1 means one more.
    __m512 k = _mm512_getexp_ps(x);
    k = _mm512_mask_add_ps(k, _mm512_cmp_ps_mask(m, one, _CMP_LT_OQ), k, one);
    const __m512 lnm = logOfAtanhArg(_mm512_div_ps(_mm512_sub_ps(m, one), _mm512_add_ps(m, one)));
    return _mm512_fmadd_ps(k, _mm512_set1_ps(0.69314718055994531f), lnm);
}

/// (e^z − 1)/z for |z| ≤ ln2/2 by its Taylor series to z⁶ (truncation < 6e−9).
inline __m512 expm1OverZ(__m512 z) {
    __m512 p = _mm512_set1_ps(1.f / 5040.f);
    p = _mm512_fmadd_ps(p, z, _mm512_set1_ps(1.f / 720.f));
    p = _mm512_fmadd_ps(p, z, _mm512_set1_ps(1.f / 120.f));
    p = _mm512_fmadd_ps(p, z, _mm512_set1_ps(1.f / 24.f));
    p = _mm512_fmadd_ps(p, z, _mm512_set1_ps(1.f / 6.f));
    p = _mm512_fmadd_ps(p, z, _mm512_set1_ps(0.5f));
    return _mm512_fmadd_ps(p, z, _mm512_set1_ps(1.f));
}

/// e^y for y ≤ 0 (−∞ gives 0): y·log2(e) = n + f with n integer, |f| ≤ ½, 2^f = e^z,
/// z = f·ln 2, as 1 + z·expm1OverZ(z), scaled by 2^n (vscalefps). Relative error
/// ≈ 1e−7·(1 + |y|) (the float rounding of y·log2(e)).
inline __m512 expNonPositivePs(__m512 y) {
    const __m512 t = _mm512_mul_ps(y, _mm512_set1_ps(1.44269504088896341f));
    const __m512 n = _mm512_roundscale_ps(t, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
    __m512 f = _mm512_sub_ps(t, n);  // NaN for t = −∞
    f = _mm512_maskz_mov_ps(_mm512_cmp_ps_mask(f, f, _CMP_ORD_Q), f);
    const __m512 z = _mm512_mul_ps(f, _mm512_set1_ps(0.69314718055994531f));
    const __m512 p = _mm512_fmadd_ps(z, expm1OverZ(z), _mm512_set1_ps(1.f));
    return _mm512_scalef_ps(p, n);  // 2^−∞ = 0
}

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

}  // namespace udvr::simd
#endif
