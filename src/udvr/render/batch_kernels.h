#pragma once
// Kernels of the batched ray loop (render/ray_march.h): float reconstruction and
// classification of 16 samples at once with AVX-512 for the models whose per-sample work is
// small enough that the classic per-sample loop would be bound by its own overhead — the mean
// field (also the ground truth and each gmm-mc realization) and quantile-mean. Each also has a
// per-sample classifyAt for machines without AVX-512. Internal to render/.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "udvr/classify/fast_tf.h"
#include "udvr/classify/sample_kernels.h"
#include "udvr/classify/transfer_function.h"
#include "udvr/util/fast_math.h"
#include "udvr/util/grid.h"
#include "udvr/util/normal_cdf.h"
#include "udvr/util/simd.h"

namespace udvr::detail {

/// Bit v of a per-cell emptiness bit table (SkipTable::cellEmptyBits).
inline bool isCellEmpty(const std::uint32_t* bits, std::size_t v) {
    return ((bits[v >> 5] >> (v & 31u)) & 1u) != 0;
}

/// Index-space geometry of a model grid's trilinear cells, as trilinearCell (SPEC §3) clamps
/// them, shared by the batched kernels.
struct CellGeometry {
    float maxIndex[3] = {0, 0, 0};  // dims − 1: index-space clamp (SPEC §3 clamps into the grid)
    int maxBase[3] = {0, 0, 0};     // last cell's base index: max(dims − 2, 0)
    std::size_t stride[3] = {0, 0, 0};  // linear stride per axis (voxels)
    std::size_t next[3] = {0, 0, 0};    // offset of the +1 neighbour (0 on a 1-point axis)
    /// Whether every voxel index fits an int (the batched loops' 32-bit indices).
    bool batchable = false;
    int stride32[3] = {0, 0, 0};
    int next32[3] = {0, 0, 0};
    // Per-cell emptiness bits (SkipTable::cellEmptyBits) or null, set by the renderer.
    const std::uint32_t* cellEmpty = nullptr;

    explicit CellGeometry(const Grid3& grid) {
        stride[0] = 1;
        stride[1] = static_cast<std::size_t>(grid.dims[0]);
        stride[2] = stride[1] * static_cast<std::size_t>(grid.dims[1]);
        for (int a = 0; a < 3; ++a) {
            maxIndex[a] = static_cast<float>(grid.dims[a] - 1);
            maxBase[a] = std::max(grid.dims[a] - 2, 0);
            next[a] = grid.dims[a] > 1 ? stride[a] : 0;
        }
        batchable = grid.pointCount() < static_cast<std::size_t>(std::numeric_limits<int>::max());
        if (batchable)
            for (int a = 0; a < 3; ++a) {
                stride32[a] = static_cast<int>(stride[a]);
                next32[a] = static_cast<int>(next[a]);
            }
    }

#if UDVR_HAVE_AVX512
    /// The ends (x, x + 1) of the x-edge at voxel offset `offset` from each lane's cell base
    /// voxel, for the `live` lanes (0 elsewhere). Where x-neighbours are adjacent (every grid
    /// but a 1-point x axis) one 64-bit gather loads both ends, so 16 edges take two 8-lane
    /// gathers: half the gathered elements of two 16-lane ones.
    /// `perVoxel` > 1: `values` holds that many floats per voxel and this reads the first.
    void edge16(const float* values, __m512i base, int offset, __mmask16 live, __m512& v0,
                __m512& v1, int perVoxel = 1) const {
        __m512i idx = _mm512_add_epi32(base, _mm512_set1_epi32(offset));
        if (perVoxel != 1) idx = _mm512_mullo_epi32(idx, _mm512_set1_epi32(perVoxel));
        if (next32[0] == 1 && perVoxel == 1) {
            const __m512i even =
                _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
            const __m512 lo = _mm512_castpd_ps(
                _mm512_mask_i32gather_pd(_mm512_setzero_pd(), static_cast<__mmask8>(live & 0xFF),
                                         _mm512_castsi512_si256(idx), values, 4));
            const __m512 hi = _mm512_castpd_ps(
                _mm512_mask_i32gather_pd(_mm512_setzero_pd(), static_cast<__mmask8>(live >> 8),
                                         _mm512_extracti64x4_epi64(idx, 1), values, 4));
            v0 = _mm512_permutex2var_ps(lo, even, hi);
            v1 = _mm512_permutex2var_ps(lo, _mm512_add_epi32(even, _mm512_set1_epi32(1)), hi);
            return;
        }
        v0 = _mm512_mask_i32gather_ps(_mm512_setzero_ps(), live, idx, values, 4);
        v1 = _mm512_mask_i32gather_ps(
            _mm512_setzero_ps(), live,
            _mm512_add_epi32(idx, _mm512_set1_epi32(next32[0] * perVoxel)), values, 4);
    }
    /// Trilinear interpolation of `values` (one per grid point) at 16 cells, by the lerps of
    /// FastMeanKernel::valueAt (x, then y, then z), `live` lanes only (0 elsewhere).
    __m512 trilinear16(const float* values, __m512i base, __m512 fx, __m512 fy, __m512 fz,
                       __mmask16 live, int perVoxel = 1) const {
        const auto lerp = [](__m512 u, __m512 v, __m512 f) {
            return _mm512_fmadd_ps(f, _mm512_sub_ps(v, u), u);
        };
        const int oy = next32[1], oz = next32[2];
        __m512 c[4];
        const int offsets[4] = {0, oy, oz, oz + oy};
        for (int r = 0; r < 4; ++r) {
            __m512 v0, v1;
            edge16(values, base, offsets[r], live, v0, v1, perVoxel);
            c[r] = lerp(v0, v1, fx);
        }
        return lerp(lerp(c[0], c[1], fy), lerp(c[2], c[3], fy), fz);
    }
#endif
};

/// Mean field with the exact fast TF: TF(trilinear(values)), the kernel of `mean`, of plain
/// fields (ground truth) and of each gmm-mc realization.
struct FastMeanKernel : CellGeometry {
    const float* values = nullptr;  // one value per grid point, x fastest
    const FastTransferFunction* tf = nullptr;
    /// valueAt()'s result for a sample in an empty cell: below every value, never classified.
    static constexpr float kEmptyCell = -std::numeric_limits<float>::infinity();

    FastMeanKernel(const Grid3& grid, const float* v, const FastTransferFunction* t)
        : CellGeometry(grid), values(v), tf(t) {}

    /// Trilinear value at an index-space point (clamped into the grid); SPEC §3 `mean`.
    float valueAt(float x, float y, float z) const {
        x = std::clamp(x, 0.f, maxIndex[0]);
        y = std::clamp(y, 0.f, maxIndex[1]);
        z = std::clamp(z, 0.f, maxIndex[2]);
        const int ix = std::min(static_cast<int>(x), maxBase[0]);
        const int iy = std::min(static_cast<int>(y), maxBase[1]);
        const int iz = std::min(static_cast<int>(z), maxBase[2]);
        const float fx = x - static_cast<float>(ix), fy = y - static_cast<float>(iy),
                    fz = z - static_cast<float>(iz);
        const std::size_t base = static_cast<std::size_t>(ix) +
                                 static_cast<std::size_t>(iy) * stride[1] +
                                 static_cast<std::size_t>(iz) * stride[2];
        if (cellEmpty && isCellEmpty(cellEmpty, base))
            return kEmptyCell;  // E[α] = 0 in the whole cell
        const float* q = values + base;
        const std::size_t ox = next[0], oy = next[1], oz = next[2];
        const float c00 = q[0] + fx * (q[ox] - q[0]);
        const float c10 = q[oy] + fx * (q[oy + ox] - q[oy]);
        const float c01 = q[oz] + fx * (q[oz + ox] - q[oz]);
        const float c11 = q[oz + oy] + fx * (q[oz + oy + ox] - q[oz + oy]);
        const float c0 = c00 + fy * (c10 - c00);
        const float c1 = c01 + fy * (c11 - c01);
        return c0 + fz * (c1 - c0);
    }
    /// Samples per batch of cellsAt/blend: one AVX-512 register of floats.
    static constexpr int kBatch = 16;

    /// valueAt's cell and weights for the kBatch samples at a + (s0 + i)·b, i < kBatch (one loop
    /// the compiler vectorises): the cell's base voxel and the fractional position in it.
    /// Samples past the end of a run are computed too; they clamp into the grid like any other.
    void cellsAt(const float a[3], const float b[3], int s0, int* base, float* fx, float* fy,
                 float* fz) const {
        const float a0 = a[0], a1 = a[1], a2 = a[2], b0 = b[0], b1 = b[1], b2 = b[2];
        const float m0 = maxIndex[0], m1 = maxIndex[1], m2 = maxIndex[2];
        const int mb0 = maxBase[0], mb1 = maxBase[1], mb2 = maxBase[2];
        const int sy = stride32[1], sz = stride32[2];
        for (int i = 0; i < kBatch; ++i) {
            const float sf = static_cast<float>(s0 + i);
            const float x = std::min(std::max(a0 + sf * b0, 0.f), m0);
            const float y = std::min(std::max(a1 + sf * b1, 0.f), m1);
            const float z = std::min(std::max(a2 + sf * b2, 0.f), m2);
            const int ix = std::min(static_cast<int>(x), mb0);
            const int iy = std::min(static_cast<int>(y), mb1);
            const int iz = std::min(static_cast<int>(z), mb2);
            fx[i] = x - static_cast<float>(ix);
            fy[i] = y - static_cast<float>(iy);
            fz[i] = z - static_cast<float>(iz);
            base[i] = ix + iy * sy + iz * sz;
        }
    }
    /// valueAt's blend (without the empty-cell test) for kBatch cells from cellsAt (gathers for
    /// the corners; every index is in range): the same operations, so the same values.
    void blend(const int* base, const float* fxs, const float* fys, const float* fzs,
               float* value) const {
        const int ox = next32[0], oy = next32[1], oz = next32[2];
        const float* q = values;
        for (int i = 0; i < kBatch; ++i) {
            const int v = base[i];
            const float fx = fxs[i], fy = fys[i], fz = fzs[i];
            const float q000 = q[v], q100 = q[v + ox], q010 = q[v + oy], q110 = q[v + oy + ox];
            const float q001 = q[v + oz], q101 = q[v + oz + ox], q011 = q[v + oz + oy],
                        q111 = q[v + oz + oy + ox];
            const float c00 = q000 + fx * (q100 - q000);
            const float c10 = q010 + fx * (q110 - q010);
            const float c01 = q001 + fx * (q101 - q001);
            const float c11 = q011 + fx * (q111 - q011);
            const float c0 = c00 + fy * (c10 - c00);
            const float c1 = c01 + fy * (c11 - c01);
            value[i] = c0 + fz * (c1 - c0);
        }
    }
    Rgba classifyAt(float x, float y, float z) const {
        const float v = valueAt(x, y, z);
        if (v == kEmptyCell) return Rgba{};
        return tf->classify(v);
    }
    void voxelSupport(std::size_t voxel, float& lo, float& hi) const { lo = hi = values[voxel]; }

#if UDVR_HAVE_AVX512
    /// Prefetch the cache lines of the cell based at voxel v (its four x-rows).
    void prefetchCell(int v) const {
        const float* q = values + v;
        __builtin_prefetch(q);
        __builtin_prefetch(q + next32[1]);
        __builtin_prefetch(q + next32[2]);
        __builtin_prefetch(q + next32[1] + next32[2]);
    }
    /// load16 loads every lane of a run, empty cells too: the gathers then need not wait for the
    /// emptiness test (they are cheap next to the wait).
    static constexpr bool kLoadDeadLanes = true;
    /// Whether load16/finish16 can run: 32-bit voxel indices and a TF with few enough regions.
    bool batch16() const { return batchable && tf->regionArrays() != nullptr; }
    /// What load16 hands to finish16: the trilinear values.
    using Loaded16 = __m512;
    /// Classification of 16 samples in two phases, so the ray loop can issue one batch's loads
    /// before it classifies the previous batch: load16 reads and blends the `live` lanes of 16
    /// cells (base voxel and fractional position, see cellsAt; other lanes are not loaded),
    /// finish16 gives TF(value) premultiplied, (α·r, α·g, α·b, α).
    Loaded16 load16(__m512i base, __m512 fx, __m512 fy, __m512 fz, __mmask16 live) const {
        return trilinear16(values, base, fx, fy, fz, live);
    }
    void finish16(Loaded16 v, __m512& pr, __m512& pg, __m512& pb, __m512& pa) const {
        __m512 r, g, b;
        FastTransferFunction::classify16(*tf->regionArrays(), v, r, g, b, pa);
        pr = _mm512_mul_ps(pa, r);
        pg = _mm512_mul_ps(pa, g);
        pb = _mm512_mul_ps(pa, b);
    }
#endif
};

#if UDVR_HAVE_AVX512
/// Premultiplied classified samples (α·r, α·g, α·b, α) of the live lanes; 0 elsewhere.
struct Rgba16 {
    __m512 r, g, b, a;
};
#endif

/// For kernels whose samples cost far more than a cell test: load16 classifies the non-empty
/// lanes only, and finish16 hands its result on.
struct ClassifyInLoad16 {
#if UDVR_HAVE_AVX512
    static constexpr bool kLoadDeadLanes = false;
    using Loaded16 = Rgba16;
    static void finish16(const Loaded16& l, __m512& pr, __m512& pg, __m512& pb, __m512& pa) {
        pr = l.r;
        pg = l.g;
        pb = l.b;
        pa = l.a;
    }
#endif
};

/// The double per-sample kernel a batched kernel stands in for: it classifies where the batched
/// loop does not run (no AVX-512, or the kernel's batch16() says no) and gives the voxel
/// supports for the skip tables.
template <class Exact>
struct PerSampleKernel {
    Exact exact;
    Rgba classifyAt(float x, float y, float z) const { return exact.classifyAt(x, y, z); }
    void voxelSupport(std::size_t voxel, float& lo, float& hi) const {
        exact.voxelSupport(voxel, lo, hi);
    }
};

/// The boundaries of a quantile population at 16 samples, for the batched quantile kernels:
/// boundaries first … first + count − 1 of a voxel-major array with `stride` floats per voxel
/// (count ≤ 16). Per sample the corners' boundaries are one vector each (masked loads), blended
/// by the lerps of FastMeanKernel::valueAt, so equal corners give exactly equal boundaries (zero
/// widths stay zero); the 16 samples' vectors are then transposed, so the classification runs
/// per boundary over all 16 samples and its sums need no horizontal additions.
struct QuantileRows : CellGeometry, ClassifyInLoad16 {
    const float* data = nullptr;
    int stride = 0;  // floats per voxel
    int first = 0;   // first boundary of the population
    int count = 0;   // boundaries in the population

    QuantileRows(const Grid3& grid, const float* d, int strideIn, int firstIn, int countIn)
        : CellGeometry(grid), data(d), stride(strideIn), first(firstIn), count(countIn) {}

#if UDVR_HAVE_AVX512
    bool rowsFit() const { return batchable && count >= 2 && count <= 16; }
    void prefetchCell(int v) const {
        const auto n = static_cast<std::size_t>(stride);
        const float* b = data + static_cast<std::size_t>(v) * n + first;
        for (int o : {0, next32[1], next32[2], next32[1] + next32[2]}) {
            __builtin_prefetch(b + static_cast<std::size_t>(o) * n);
            __builtin_prefetch(b + (static_cast<std::size_t>(o) + 1) * n + count - 1);
        }
    }
    /// rows[j] = boundary first + j at the 16 samples (0 in lanes outside `live`), j < count;
    /// with `widths`, also widths[j] = b_{j+1} − b_j interpolated from the corners' own widths
    /// (not the difference of two interpolated boundaries, which loses the digits of |b| and
    /// which 1/w would magnify), j < count − 1.
    void rows16(__m512i base, __m512 fx, __m512 fy, __m512 fz, __mmask16 live, __m512 rows[16],
                __m512* widths = nullptr) const {
        alignas(64) int cell[16];
        alignas(64) float w[3][16];
        _mm512_store_si512(cell, base);
        _mm512_store_ps(w[0], fx);
        _mm512_store_ps(w[1], fy);
        _mm512_store_ps(w[2], fz);
        for (int l = 0; l < 16; ++l) {
            rows[l] = _mm512_setzero_ps();
            if (widths) widths[l] = _mm512_setzero_ps();
            if (live >> l & 1)
                rows[l] =
                    boundaries(cell[l], w[0][l], w[1][l], w[2][l], widths ? &widths[l] : nullptr);
        }
        simd::transpose16(rows);
        if (widths) simd::transpose16(widths);
    }

  private:
    /// The boundaries (and, with `width`, the widths) at one sample.
    __m512 boundaries(int v, float fx, float fy, float fz, __m512* width = nullptr) const {
        const __mmask16 m = static_cast<__mmask16>((1u << count) - 1u);
        const auto n = static_cast<std::size_t>(stride);
        const float* b = data + static_cast<std::size_t>(v) * n + first;
        const auto at = [&](int o) {
            return _mm512_maskz_loadu_ps(m, b + static_cast<std::size_t>(o) * n);
        };
        const auto lerp = [](__m512 u, __m512 w, float f) {
            return _mm512_fmadd_ps(_mm512_set1_ps(f), _mm512_sub_ps(w, u), u);
        };
        const int ox = next32[0], oy = next32[1], oz = next32[2];
        const int offsets[8] = {0, ox, oy, oy + ox, oz, oz + ox, oz + oy, oz + oy + ox};
        __m512 corner[8];
        for (int c = 0; c < 8; ++c) corner[c] = at(offsets[c]);
        const auto blend = [&](const __m512* q) {
            const __m512 c00 = lerp(q[0], q[1], fx), c10 = lerp(q[2], q[3], fx);
            const __m512 c01 = lerp(q[4], q[5], fx), c11 = lerp(q[6], q[7], fx);
            return lerp(lerp(c00, c10, fy), lerp(c01, c11, fy), fz);
        };
        if (width) {
            __m512 cw[8];  // each corner's b_{j+1} − b_j in lane j
            for (int c = 0; c < 8; ++c)
                cw[c] =
                    _mm512_sub_ps(_mm512_castsi512_ps(_mm512_alignr_epi32(
                                      _mm512_setzero_si512(), _mm512_castps_si512(corner[c]), 1)),
                                  corner[c]);
            *width = blend(cw);
        }
        return blend(corner);
    }
#endif
};

/// Quantile mean (Eq. 5, SPEC §4) in float for 16 samples at a time (QuantileRows): per
/// quantile j the midpoints, widths and weights over all samples and the TF at the midpoints
/// by region permutes (FastTransferFunction). Density weights 1/w_j (`quantile-mean`) or equal
/// weights (`quantile-mean-mass`); with density weights, zero-width quantiles (w ≤ zeroWidth)
/// take all the mass, shared equally, as in QuantileMeanKernel. Same values as
/// QuantileMeanKernel (double) up to float rounding.
struct FastQuantileMeanKernel : QuantileRows, PerSampleKernel<QuantileMeanKernel> {
    int q = 0;
    bool densityWeights = true;
    float zeroWidth = 0.f;  // data units
    const FastTransferFunction* tf = nullptr;

    FastQuantileMeanKernel(const Grid3& grid, const QuantileMeanKernel& k,
                           const FastTransferFunction* t)
        : QuantileRows(grid, k.quantiles, k.q + 1, 0, k.q + 1),
          PerSampleKernel<QuantileMeanKernel>{k},
          q(k.q),
          densityWeights(k.densityWeights),
          zeroWidth(static_cast<float>(k.zeroWidth)),
          tf(t) {}

#if UDVR_HAVE_AVX512
    /// q + 1 boundaries fit one vector, 32-bit indices, a TF with few enough regions.
    bool batch16() const { return rowsFit() && tf->regionArrays() != nullptr; }
    Loaded16 load16(__m512i base, __m512 fx, __m512 fy, __m512 fz, __mmask16 live) const {
        __m512 b[16], widths[16];
        rows16(base, fx, fy, fz, live, b, widths);
        // Eq. 5 per lane: Σ_j p_j·TF(m_j) / Σ_j p_j, and, for density weights, the same with
        // p_j = 1 over the zero-width quantiles alone (used where a lane has any).
        const __m512 one = _mm512_set1_ps(1.f), half = _mm512_set1_ps(0.5f),
                     zeroWidthV = _mm512_set1_ps(zeroWidth);
        __m512 sum[4], zeroSum[4], weightSum = _mm512_setzero_ps(), zeroCount = weightSum;
        for (int c = 0; c < 4; ++c) sum[c] = zeroSum[c] = _mm512_setzero_ps();
        __mmask16 anyZero = 0;
        for (int j = 0; j < q; ++j) {
            const __m512 mid = _mm512_mul_ps(_mm512_add_ps(b[j], b[j + 1]), half);
            const __m512 width = widths[j];
            __m512 r, g, bl, a;
            FastTransferFunction::classify16(*tf->regionArrays(), mid, r, g, bl, a);
            const __m512 premult[4] = {_mm512_mul_ps(a, r), _mm512_mul_ps(a, g),
                                       _mm512_mul_ps(a, bl), a};
            const __m512 weight = densityWeights ? _mm512_div_ps(one, width) : one;
            for (int c = 0; c < 4; ++c) sum[c] = _mm512_fmadd_ps(weight, premult[c], sum[c]);
            weightSum = _mm512_add_ps(weightSum, weight);
            if (densityWeights) {
                const __mmask16 zero = _mm512_mask_cmp_ps_mask(live, width, zeroWidthV, _CMP_LE_OQ);
                if (zero) {
                    anyZero |= zero;
                    for (int c = 0; c < 4; ++c)
                        zeroSum[c] = _mm512_mask_add_ps(zeroSum[c], zero, zeroSum[c], premult[c]);
                    zeroCount = _mm512_mask_add_ps(zeroCount, zero, zeroCount, one);
                }
            }
        }
        __m512 out[4];
        for (int c = 0; c < 4; ++c)
            out[c] = _mm512_maskz_mov_ps(live, _mm512_mask_div_ps(_mm512_div_ps(sum[c], weightSum),
                                                                  anyZero, zeroSum[c], zeroCount));
        return Loaded16{out[0], out[1], out[2], out[3]};
    }
#endif
};

/// The exact TF pieces of a TfTable (SPEC §4; at most 32 pieces) in float arrays for region
/// permutes: piece k = number of breakpoints ≤ x, channel ch (α·r, α·g, α·b, α) is
/// a + b·t + c·t² with t = x − origin, cum = ∫ TF from u_0 to the piece's origin.
struct TfPieces16 {
    static constexpr int kMax = 32;
    bool fits = false;
    int breakCount = 0;
    alignas(64) float bound[kMax];  // u_0 … u_{N−1}, then +inf
    alignas(64) float origin[kMax];
    alignas(64) float a[4][kMax], b[4][kMax], c[4][kMax];
    // cum = cumHi + cumLo (a float pair, ~48 bits): the difference of two prefix sums for the
    // full pieces inside an interval then keeps its digits when the sums are large.
    alignas(64) float cumHi[4][kMax], cumLo[4][kMax];
    // The float Gaussian expectation differences Φ and φ at the ends of a piece; their float
    // rounding (~6e−8) is multiplied by up to (σ/w)² for a piece of width w, so lanes with
    // σ > kMaxSigmaOverWidth × (narrowest interior piece) take the double kernel (error then
    // < 6e−8·8² ≈ 4e−6).
    static constexpr float kMaxSigmaOverWidth = 8.f;
    float maxFloatSigma = std::numeric_limits<float>::infinity();

    explicit TfPieces16(const TfTable& t) {
        fits = t.breakCount + 1 <= kMax;
        if (!fits) return;
        breakCount = t.breakCount;
        for (int k = 0; k + 1 < t.breakCount; ++k)
            maxFloatSigma =
                std::min(maxFloatSigma,
                         kMaxSigmaOverWidth * static_cast<float>(t.breaks[k + 1] - t.breaks[k]));
        for (int k = 0; k < kMax; ++k) {
            bound[k] = k < t.breakCount ? static_cast<float>(t.breaks[k])
                                        : std::numeric_limits<float>::infinity();
            const TfPiece& p = t.pieces[std::min(k, t.breakCount)];
            origin[k] = static_cast<float>(p.origin);
            for (int ch = 0; ch < 4; ++ch) {
                a[ch][k] = static_cast<float>(p.a[ch]);
                b[ch][k] = static_cast<float>(p.b[ch]);
                c[ch][k] = static_cast<float>(p.c[ch]);
                cumHi[ch][k] = static_cast<float>(p.cum[ch]);
                cumLo[ch][k] = static_cast<float>(p.cum[ch] - static_cast<double>(cumHi[ch][k]));
            }
        }
    }

#if UDVR_HAVE_AVX512
    __m512i pieceOf(__m512 x) const { return FastTransferFunction::region16(bound, breakCount, x); }
    /// TfTable::meanOver for 16 intervals [lo, hi] with pieces kl, kh: the mean of the TF
    /// channels over the interval, TF(hi) where hi ≤ lo; partial pieces at both ends plus the
    /// prefix-sum difference of the full pieces between them (no cancellation for tiny
    /// intervals).
    void meanOver(__m512 lo, __m512 hi, __m512i kl, __m512i kh, __m512 out[4]) const {
        const auto pick = [](const float* f, __m512i k) {
            return _mm512_permutex2var_ps(_mm512_load_ps(f), k, _mm512_load_ps(f + 16));
        };
        const __m512 third = _mm512_set1_ps(1.f / 3.f), half = _mm512_set1_ps(0.5f);
        // Σ of a + b·t + c·t² over [tl, th] divided by th − tl: a + b·s1 + c·s2.
        const auto s1s2 = [&](__m512 tl, __m512 th, __m512& s1, __m512& s2) {
            s1 = _mm512_mul_ps(_mm512_add_ps(tl, th), half);
            s2 = _mm512_mul_ps(
                _mm512_fmadd_ps(tl, tl, _mm512_fmadd_ps(tl, th, _mm512_mul_ps(th, th))), third);
        };
        const auto poly = [&](int ch, __m512i k, __m512 s1, __m512 s2) {
            return _mm512_fmadd_ps(pick(c[ch], k), s2,
                                   _mm512_fmadd_ps(pick(b[ch], k), s1, pick(a[ch], k)));
        };
        const __m512 ol = pick(origin, kl);
        const __m512 tl = _mm512_sub_ps(lo, ol), th = _mm512_sub_ps(hi, ol);
        __m512 s1, s2;
        s1s2(tl, th, s1, s2);
        for (int ch = 0; ch < 4; ++ch) out[ch] = poly(ch, kl, s1, s2);  // kl == kh
        const __mmask16 zero = _mm512_cmp_ps_mask(hi, lo, _CMP_NGT_UQ);
        const __mmask16 span = _mm512_cmpneq_epi32_mask(kl, kh) & static_cast<__mmask16>(~zero);
        if (zero) {  // TF(hi) on piece kh
            const __m512 t = _mm512_sub_ps(hi, pick(origin, kh));
            for (int ch = 0; ch < 4; ++ch)
                out[ch] = _mm512_mask_mov_ps(
                    out[ch], zero,
                    _mm512_fmadd_ps(t, _mm512_fmadd_ps(t, pick(c[ch], kh), pick(b[ch], kh)),
                                    pick(a[ch], kh)));
        }
        if (span) {
            // Left: [lo, u_kl] on piece kl; right: [origin_kh, hi] on piece kh; between: full
            // pieces kl+1 … kh−1, cum[kh] − cum[kl+1].
            const __m512 end = pick(bound, kl);
            const __m512 te = _mm512_sub_ps(end, ol), wl = _mm512_sub_ps(end, lo);
            __m512 ls1, ls2, rs1, rs2;
            s1s2(tl, te, ls1, ls2);
            const __m512 tr = _mm512_sub_ps(hi, pick(origin, kh));
            s1s2(_mm512_setzero_ps(), tr, rs1, rs2);
            const __m512i next = _mm512_add_epi32(kl, _mm512_set1_epi32(1));
            const __m512 inv = _mm512_div_ps(_mm512_set1_ps(1.f), _mm512_sub_ps(hi, lo));
            for (int ch = 0; ch < 4; ++ch) {
                const __m512 left = _mm512_mul_ps(wl, poly(ch, kl, ls1, ls2));
                const __m512 right = _mm512_mul_ps(tr, poly(ch, kh, rs1, rs2));
                const __m512 full =
                    _mm512_add_ps(_mm512_sub_ps(pick(cumHi[ch], kh), pick(cumHi[ch], next)),
                                  _mm512_sub_ps(pick(cumLo[ch], kh), pick(cumLo[ch], next)));
                out[ch] = _mm512_mask_mul_ps(out[ch], span,
                                             _mm512_add_ps(_mm512_add_ps(left, full), right), inv);
            }
        }
    }
#endif
};

/// Quantile range (Eq. 4, SPEC §4) in float for 16 samples at a time (QuantileRows): the mean
/// of the TF over each quantile interval [b_j, b_{j+1}] of the population (TfPieces16), averaged
/// with equal weights. Serves quantile-range, the quartile views and iqr, like
/// QuantileRangeKernel (double), whose values it matches up to float rounding.
struct FastQuantileRangeKernel : QuantileRows, PerSampleKernel<QuantileRangeKernel> {
    const TfPieces16* pieces = nullptr;

    FastQuantileRangeKernel(const Grid3& grid, const QuantileRangeKernel& k, const TfPieces16* p)
        : QuantileRows(grid, k.boundaries, k.stride, k.j0, k.j1 - k.j0 + 1),
          PerSampleKernel<QuantileRangeKernel>{k},
          pieces(p) {}

#if UDVR_HAVE_AVX512
    bool batch16() const { return rowsFit() && pieces->fits; }
    Loaded16 load16(__m512i base, __m512 fx, __m512 fy, __m512 fz, __mmask16 live) const {
        __m512 b[16];
        rows16(base, fx, fy, fz, live, b);
        __m512 sum[4];
        for (auto& v : sum) v = _mm512_setzero_ps();
        __m512i kLo = pieces->pieceOf(b[0]);
        for (int j = 0; j + 1 < count; ++j) {
            const __m512i kHi = pieces->pieceOf(b[j + 1]);
            __m512 m[4];
            pieces->meanOver(b[j], b[j + 1], kLo, kHi, m);
            for (int c = 0; c < 4; ++c) sum[c] = _mm512_add_ps(sum[c], m[c]);
            kLo = kHi;
        }
        const __m512 inv = _mm512_set1_ps(1.f / static_cast<float>(count - 1));
        return Loaded16{
            _mm512_maskz_mul_ps(live, sum[0], inv), _mm512_maskz_mul_ps(live, sum[1], inv),
            _mm512_maskz_mul_ps(live, sum[2], inv), _mm512_maskz_mul_ps(live, sum[3], inv)};
    }
#endif
};

#if UDVR_HAVE_AVX512
/// expectedTfGaussian for 16 lanes of N(μ, σ²) (var = σ²; σ = 0 is the point mass TF(μ)).
inline void gaussianExpectation16(const TfPieces16& t, __m512 mu, __m512 sigma, __m512 var,
                                  __mmask16 live, __m512 out[4]) {
    const __m512 cutoff = _mm512_mul_ps(_mm512_set1_ps(7.f), sigma);  // kGaussianCutoffSigmas
    const __m512i kl = t.pieceOf(_mm512_sub_ps(mu, cutoff));
    const __m512i kh = t.pieceOf(_mm512_add_ps(mu, cutoff));
    // One piece (also σ = 0, where kl = kh = μ's piece): E[p(X)] = p(μ) + c·σ².
    {
        const auto pick = [&](const float* f) {
            return _mm512_permutex2var_ps(_mm512_load_ps(f), kl, _mm512_load_ps(f + 16));
        };
        const __m512 d = _mm512_sub_ps(mu, pick(t.origin));
        for (int ch = 0; ch < 4; ++ch) {
            const __m512 c = pick(t.c[ch]);
            out[ch] = _mm512_fmadd_ps(
                c, var, _mm512_fmadd_ps(d, _mm512_fmadd_ps(d, c, pick(t.b[ch])), pick(t.a[ch])));
        }
    }
    const __mmask16 spread = _mm512_mask_cmpneq_epi32_mask(live, kl, kh);
    if (!spread) return;
    for (int ch = 0; ch < 4; ++ch)
        out[ch] = _mm512_mask_mov_ps(out[ch], spread, _mm512_setzero_ps());
    // Φ (cdf), 1 − Φ (upper), φ and z·φ at the left end of the current piece; the first
    // piece of a lane starts at z = −∞.
    __m512 cdfA = _mm512_setzero_ps(), upA = _mm512_set1_ps(1.f), pdfA = cdfA, zpdfA = cdfA;
    __mmask16 upperA = 0;  // z_a ≥ 0
    const __m512 invSigma = _mm512_div_ps(_mm512_set1_ps(1.f), sigma);
    const int kFirst = _mm512_mask_reduce_min_epi32(spread, kl);
    const int kLast = _mm512_mask_reduce_max_epi32(spread, kh);
    for (int k = kFirst; k <= kLast; ++k) {
        const __m512i kv = _mm512_set1_epi32(k);
        const __mmask16 on =
            spread & _mm512_cmple_epi32_mask(kl, kv) & _mm512_cmpge_epi32_mask(kh, kv);
        if (!on) continue;
        const __mmask16 last = on & _mm512_cmpeq_epi32_mask(kh, kv);
        // z_b at the piece's right end u_k (k < kh), +∞ for the lane's last piece.
        __m512 cdfB = _mm512_set1_ps(1.f), upB = _mm512_setzero_ps(), pdfB = upB, zpdfB = upB;
        __mmask16 upperB = last;
        if (on & ~last) {
            const __m512 z = _mm512_mul_ps(_mm512_sub_ps(_mm512_set1_ps(t.bound[k]), mu), invSigma);
            const __m512 g =
                expNonPositive(_mm512_mul_ps(_mm512_set1_ps(-0.5f), _mm512_mul_ps(z, z)));
            const __m512 az = _mm512_abs_ps(z);
            const __m512 tail = _mm512_mul_ps(
                _mm512_mul_ps(_mm512_set1_ps(0.5f), g),
                erfcxNonNegative(_mm512_mul_ps(az, _mm512_set1_ps(0.70710678118654752f))));
            const __mmask16 pos = _mm512_cmp_ps_mask(z, _mm512_setzero_ps(), _CMP_GE_OQ);
            const __m512 rest = _mm512_sub_ps(_mm512_set1_ps(1.f), tail);
            const __mmask16 mid = on & ~last;
            cdfB = _mm512_mask_mov_ps(cdfB, mid, _mm512_mask_mov_ps(tail, pos, rest));
            upB = _mm512_mask_mov_ps(upB, mid, _mm512_mask_mov_ps(rest, pos, tail));
            pdfB = _mm512_mask_mov_ps(pdfB, mid,
                                      _mm512_mul_ps(_mm512_set1_ps(0.39894228040143268f), g));
            zpdfB = _mm512_mask_mov_ps(zpdfB, mid, _mm512_mul_ps(z, pdfB));
            upperB = static_cast<__mmask16>((upperB & ~mid) | (pos & mid));
        }
        // ∫ z^m φ over [z_a, z_b]: m0 = ΔΦ (between upper tails where z_a ≥ 0),
        // m1 = φ(z_a) − φ(z_b), m2 = m0 + z_a φ(z_a) − z_b φ(z_b).
        const __m512 m0 = _mm512_mask_sub_ps(_mm512_sub_ps(cdfB, cdfA), upperA, upA, upB);
        const __m512 m1 = _mm512_sub_ps(pdfA, pdfB);
        const __m512 m2 = _mm512_add_ps(m0, _mm512_sub_ps(zpdfA, zpdfB));
        const __m512 d = _mm512_sub_ps(mu, _mm512_set1_ps(t.origin[k]));  // x − origin = d + σz
        for (int ch = 0; ch < 4; ++ch) {
            const __m512 pa = _mm512_set1_ps(t.a[ch][k]), pb = _mm512_set1_ps(t.b[ch][k]),
                         pc = _mm512_set1_ps(t.c[ch][k]);
            const __m512 a = _mm512_fmadd_ps(d, _mm512_fmadd_ps(d, pc, pb), pa);
            const __m512 b = _mm512_mul_ps(_mm512_fmadd_ps(_mm512_add_ps(pc, pc), d, pb), sigma);
            const __m512 c = _mm512_mul_ps(pc, var);
            const __m512 term =
                _mm512_fmadd_ps(a, m0, _mm512_fmadd_ps(b, m1, _mm512_mul_ps(c, m2)));
            out[ch] = _mm512_mask_add_ps(out[ch], on, out[ch], term);
        }
        cdfA = _mm512_mask_mov_ps(cdfA, on, cdfB);
        upA = _mm512_mask_mov_ps(upA, on, upB);
        pdfA = _mm512_mask_mov_ps(pdfA, on, pdfB);
        zpdfA = _mm512_mask_mov_ps(zpdfA, on, zpdfB);
        upperA = static_cast<__mmask16>((upperA & ~on) | (upperB & on));
    }
}
#endif

#if UDVR_HAVE_AVX512
/// out[c] ← the double kernel's classification in the `lanes` of a batch (cells from base and
/// fractions, as the ray loop computes them; the point is base index + fraction).
template <class Exact>
void exactLanes(const Exact& exact, const CellGeometry& g, __m512i base, __m512 fx, __m512 fy,
                __m512 fz, __mmask16 lanes, __m512 out[4]) {
    alignas(64) int cell[16];
    alignas(64) float f[3][16], o[4][16];
    _mm512_store_si512(cell, base);
    _mm512_store_ps(f[0], fx);
    _mm512_store_ps(f[1], fy);
    _mm512_store_ps(f[2], fz);
    for (int c = 0; c < 4; ++c) _mm512_store_ps(o[c], out[c]);
    for (unsigned m = lanes; m; m &= m - 1) {
        const int l = __builtin_ctz(m);
        const auto v = static_cast<std::size_t>(cell[l]);
        const std::size_t iz = v / g.stride[2], rest = v % g.stride[2];
        const std::size_t iy = rest / g.stride[1], ix = rest % g.stride[1];
        const Rgba c =
            exact.classifyAt(static_cast<float>(ix) + f[0][l], static_cast<float>(iy) + f[1][l],
                             static_cast<float>(iz) + f[2][l]);
        o[0][l] = c.r;
        o[1][l] = c.g;
        o[2][l] = c.b;
        o[3][l] = c.a;
    }
    for (int c = 0; c < 4; ++c) out[c] = _mm512_load_ps(o[c]);
}
#endif

/// Gaussian (SPEC §3–4) in float for 16 samples at a time: μ = Σ w_c μ_c by the mean field's
/// lerps, σ² = Σ w_c² σ_c², then E[TF(X)], X ~ N(μ, σ²), in closed form per TF piece as
/// expectedTfGaussian: pieces from the one of μ − 7σ to the one of μ + 7σ, each piece's
/// polynomial against φ by Φ and φ at its ends. The loop runs over the pieces any lane needs;
/// the piece coefficients are broadcasts. Φ differences of the upper tail are taken between
/// tails (1 − Φ), so no lane loses digits to 1 − tiny. Lanes whose σ is wide against the TF's
/// narrowest piece take the double kernel (TfPieces16::maxFloatSigma). Same values as
/// GaussianKernel (double) up to float rounding.
struct FastGaussianKernel : CellGeometry, ClassifyInLoad16, PerSampleKernel<GaussianKernel> {
    const float* mean = nullptr;
    const float* stddev = nullptr;
    const TfPieces16* pieces = nullptr;

    FastGaussianKernel(const Grid3& grid, const GaussianKernel& k, const TfPieces16* p)
        : CellGeometry(grid),
          PerSampleKernel<GaussianKernel>{k},
          mean(k.mean),
          stddev(k.stddev),
          pieces(p) {}

#if UDVR_HAVE_AVX512
    bool batch16() const { return batchable && pieces->fits; }
    void prefetchCell(int v) const {
        for (const float* a : {mean, stddev})
            for (int o : {0, next32[1], next32[2], next32[1] + next32[2]})
                __builtin_prefetch(a + v + o);
    }
    Loaded16 load16(__m512i base, __m512 fx, __m512 fy, __m512 fz, __mmask16 live) const {
        const __m512 one = _mm512_set1_ps(1.f), zero = _mm512_setzero_ps();
        const __m512 mu = trilinear16(mean, base, fx, fy, fz, live);
        // σ² = Σ_c w_c² σ_c², w_c the products of (1 − f) and f per axis.
        const __m512 gx[2] = {_mm512_sub_ps(one, fx), fx}, gy[2] = {_mm512_sub_ps(one, fy), fy},
                     gz[2] = {_mm512_sub_ps(one, fz), fz};
        const int offsets[4] = {0, next32[1], next32[2], next32[1] + next32[2]};
        __m512 var = zero;
        for (int r = 0; r < 4; ++r) {
            __m512 s0, s1;
            edge16(stddev, base, offsets[r], live, s0, s1);
            const __m512 wyz = _mm512_mul_ps(gy[r & 1], gz[r >> 1]);
            const __m512 w0 = _mm512_mul_ps(gx[0], wyz), w1 = _mm512_mul_ps(gx[1], wyz);
            const __m512 a0 = _mm512_mul_ps(w0, s0), a1 = _mm512_mul_ps(w1, s1);
            var = _mm512_fmadd_ps(a0, a0, _mm512_fmadd_ps(a1, a1, var));
        }
        // σ = 0 (or NaN) is the point mass TF(μ), as in expectedTfGaussian.
        const __mmask16 spread = _mm512_cmp_ps_mask(var, zero, _CMP_GT_OQ);
        var = _mm512_maskz_mov_ps(spread, var);
        const __m512 sigma = _mm512_sqrt_ps(var);
        const __mmask16 wide =
            live & _mm512_cmp_ps_mask(sigma, _mm512_set1_ps(pieces->maxFloatSigma), _CMP_GT_OQ);
        __m512 out[4];
        gaussianExpectation16(*pieces, mu, sigma, var, live & ~wide, out);
        if (wide) exactLanes(exact, *this, base, fx, fy, fz, wide, out);
        return Loaded16{_mm512_maskz_mov_ps(live, out[0]), _mm512_maskz_mov_ps(live, out[1]),
                        _mm512_maskz_mov_ps(live, out[2]), _mm512_maskz_mov_ps(live, out[3])};
    }

#endif
};

/// GMM (ordered) (SPEC §3–4) in float for 16 samples at a time: per rank k, π_k, μ_k and σ_k
/// interpolated trilinearly from the corners' k'th components (the mean field's lerps), π
/// normalised to Σπ = 1 (left 0 where all are 0), then Σ_k π_k·E[TF(N(μ_k, σ_k²))]
/// (gaussianExpectation16). Same values as GmmOrderedKernel (double) up to float rounding.
struct FastGmmOrderedKernel : CellGeometry, ClassifyInLoad16, PerSampleKernel<GmmOrderedKernel> {
    const float* gmm = nullptr;  // π_1..π_K, μ_1..μ_K, σ_1..σ_K per voxel
    int components = 0;
    const TfPieces16* pieces = nullptr;

    FastGmmOrderedKernel(const Grid3& grid, const GmmOrderedKernel& k, const TfPieces16* p)
        : CellGeometry(grid),
          PerSampleKernel<GmmOrderedKernel>{k},
          gmm(k.gmm),
          components(k.components),
          pieces(p) {
        // Gathers index floats with 32-bit lanes: 3K floats per voxel must keep them in range.
        fitsInt = static_cast<double>(grid.pointCount()) * 3.0 * components <
                  static_cast<double>(std::numeric_limits<int>::max());
    }

#if UDVR_HAVE_AVX512
    bool batch16() const {
        return batchable && fitsInt && components >= 1 && components <= kMaxGmmComponents &&
               pieces->fits;
    }
    void prefetchCell(int v) const {
        const std::size_t n = 3 * static_cast<std::size_t>(components);
        for (int o : {0, next32[1], next32[2], next32[1] + next32[2]})
            __builtin_prefetch(gmm + (static_cast<std::size_t>(v) + o) * n);
    }
    Loaded16 load16(__m512i base, __m512 fx, __m512 fy, __m512 fz, __mmask16 live) const {
        const int k = components, n = 3 * k;
        __m512 pi[kMaxGmmComponents], mu[kMaxGmmComponents], sigma[kMaxGmmComponents];
        __m512 total = _mm512_setzero_ps();
        for (int i = 0; i < k; ++i) {
            pi[i] = trilinear16(gmm + i, base, fx, fy, fz, live, n);
            mu[i] = trilinear16(gmm + k + i, base, fx, fy, fz, live, n);
            sigma[i] = trilinear16(gmm + 2 * k + i, base, fx, fy, fz, live, n);
            total = _mm512_add_ps(total, pi[i]);
        }
        const __mmask16 normalise = _mm512_cmp_ps_mask(total, _mm512_setzero_ps(), _CMP_GT_OQ);
        __mmask16 wide = 0;  // a component too wide for the float expectation: double lanes
        for (int i = 0; i < k; ++i)
            wide |= _mm512_cmp_ps_mask(sigma[i], _mm512_set1_ps(pieces->maxFloatSigma), _CMP_GT_OQ);
        wide &= live;
        const __m512 inv = _mm512_div_ps(_mm512_set1_ps(1.f), total);
        __m512 out[4];
        for (auto& o : out) o = _mm512_setzero_ps();
        for (int i = 0; i < k; ++i) {
            const __m512 w = _mm512_mask_mul_ps(pi[i], normalise, pi[i], inv);
            const __mmask16 on =
                live & ~wide & _mm512_cmp_ps_mask(w, _mm512_setzero_ps(), _CMP_NEQ_UQ);
            if (!on) continue;
            // σ ≤ 0 (or NaN) is the point mass, as in expectedTfGaussian.
            const __m512 s = _mm512_maskz_mov_ps(
                _mm512_cmp_ps_mask(sigma[i], _mm512_setzero_ps(), _CMP_GT_OQ), sigma[i]);
            __m512 e[4];
            gaussianExpectation16(*pieces, mu[i], s, _mm512_mul_ps(s, s), on, e);
            for (int c = 0; c < 4; ++c) out[c] = _mm512_mask3_fmadd_ps(w, e[c], out[c], on);
        }
        if (wide) exactLanes(exact, *this, base, fx, fy, fz, wide, out);
        return Loaded16{_mm512_maskz_mov_ps(live, out[0]), _mm512_maskz_mov_ps(live, out[1]),
                        _mm512_maskz_mov_ps(live, out[2]), _mm512_maskz_mov_ps(live, out[3])};
    }
#endif

  private:
    bool fitsInt = false;
};

}  // namespace udvr::detail
