#pragma once
// An exact, fast evaluator of a piecewise-linear 1D transfer function (SPEC §4) for the ray loop:
// the colour and opacity breakpoints are merged into regions on which α(x) and c(x) are both
// linear, so TF(x) = (α·c, α) needs one bucket load and a few multiply-adds. Same values as
// TransferFunction1D::classify up to float rounding, including right-continuous steps and
// clamping outside the control points.
//
// Exactness of the lookup: the bucket of x is k(x) = ⌊(x − u_0)·s⌋ in float arithmetic, a
// non-decreasing function of x. So every breakpoint in a lower bucket than x's is ≤ x and every
// one in a higher bucket is > x; only the breakpoints in x's own bucket (usually none or one)
// need a comparison. Buckets on which α ≡ 0 are flagged, so transparent samples cost one load.
#include <vector>

#include "udvr/classify/transfer_function.h"
#include "udvr/util/simd.h"

namespace udvr {

class FastTransferFunction {
  public:
    explicit FastTransferFunction(const TransferFunction1D& tf);

    /// (α·r, α·g, α·b, α) at data value x.
    Rgba classify(float x) const {
        float fb = (x - bounds_[0]) * scale_;
        fb = fb > 0.f ? fb : 0.f;  // also maps NaN to bucket 0
        fb = fb < maxBucket_ ? fb : maxBucket_;
        const Bucket& bk = buckets_[static_cast<int>(fb)];
        if (bk.base < 0) return Rgba{};  // α ≡ 0 on this bucket: what the region would give
        int r = bk.base + (x >= bk.split ? 1 : 0);
        if (bk.extra) {  // two or more breakpoints in this bucket (rare): scan them
            const int nb = static_cast<int>(bounds_.size());
            r = bk.base;
            while (r < nb && x >= bounds_[r]) ++r;
        }
        const Region& g = regions_[r];
        const float dx = x - g.x0;
        const float a = g.a0 + g.as * dx;
        const float cr = g.c0[0] + g.cs[0] * dx;
        const float cg = g.c0[1] + g.cs[1] * dx;
        const float cb = g.c0[2] + g.cs[2] * dx;
        return Rgba{a * cr, a * cg, a * cb, a};
    }

    /// Regions as arrays for SIMD lookups: region r of x is the number of breakpoints ≤ x
    /// (NaN: 0), the same region classify() finds.
    static constexpr int kMaxSimdRegions = 32;
    struct RegionArrays {
        int boundCount = 0;                        // N ≤ kMaxSimdRegions − 1
        alignas(64) float bound[kMaxSimdRegions];  // u_0 … u_{N−1}, then +inf
        alignas(64) float x0[kMaxSimdRegions], a0[kMaxSimdRegions], as[kMaxSimdRegions];
        alignas(64) float c0[3][kMaxSimdRegions], cs[3][kMaxSimdRegions];
    };
    /// The region arrays, or null when the TF has more than kMaxSimdRegions regions.
    const RegionArrays* regionArrays() const { return simdFits_ ? &arrays_ : nullptr; }

#if UDVR_HAVE_AVX512
    /// Region (number of breakpoints ≤ x; NaN: 0) of 16 values by binary search over `bound`:
    /// `count` ≤ 31 sorted breakpoints padded with +inf to 32 floats.
    static __m512i region16(const float* bound, int count, __m512 x) {
        const __m512 lo = _mm512_load_ps(bound), hi = _mm512_load_ps(bound + 16);
        __m512i reg = _mm512_setzero_si512();
        // r ← r + step where x ≥ u_{r+step−1}.
        for (int step = count < 16 ? 8 : 16; step >= 1; step >>= 1) {
            const __m512i cand = _mm512_add_epi32(reg, _mm512_set1_epi32(step));
            const __m512 u =
                _mm512_permutex2var_ps(lo, _mm512_sub_epi32(cand, _mm512_set1_epi32(1)), hi);
            reg = _mm512_mask_mov_epi32(reg, _mm512_cmp_ps_mask(x, u, _CMP_GE_OQ), cand);
        }
        return _mm512_min_epi32(reg, _mm512_set1_epi32(count));  // x = +inf
    }
    /// classify() of 16 values at once (needs regionArrays()): α and the straight colour.
    static void classify16(const RegionArrays& t, __m512 x, __m512& r, __m512& g, __m512& b,
                           __m512& a) {
        const __m512i reg = region16(t.bound, t.boundCount, x);
        const auto pick = [&](const float* f) {
            return _mm512_permutex2var_ps(_mm512_load_ps(f), reg, _mm512_load_ps(f + 16));
        };
        const __m512 dx = _mm512_sub_ps(x, pick(t.x0));
        a = _mm512_fmadd_ps(pick(t.as), dx, pick(t.a0));
        r = _mm512_fmadd_ps(pick(t.cs[0]), dx, pick(t.c0[0]));
        g = _mm512_fmadd_ps(pick(t.cs[1]), dx, pick(t.c0[1]));
        b = _mm512_fmadd_ps(pick(t.cs[2]), dx, pick(t.c0[2]));
    }
#endif

  private:
    struct Region {
        float x0;            // left end (data units); the region is [x0, next boundary)
        float a0, as;        // α = a0 + as·(x − x0)
        float c0[3], cs[3];  // c = c0 + cs·(x − x0)
    };
    struct Bucket {
        float split;  // the breakpoint inside this bucket (+inf when none)
        int base;  // breakpoints in lower buckets = region of the bucket's left part; −1: α ≡ 0
        int extra;  // 1 when the bucket holds more than one breakpoint
    };

    std::vector<float> bounds_;    // merged breakpoints u_0 < … < u_{N−1}
    std::vector<Region> regions_;  // N + 1 regions: (−∞, u_0), [u_0, u_1), …, [u_{N−1}, ∞)
    std::vector<Bucket> buckets_;
    float scale_ = 0.f;      // buckets per data unit
    float maxBucket_ = 0.f;  // index of the last bucket
    bool simdFits_ = false;
    RegionArrays arrays_;
};

}  // namespace udvr
