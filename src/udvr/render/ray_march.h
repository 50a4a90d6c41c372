#pragma once
// The ray loop of the CPU ray caster (SPEC §5), templated on the per-sample kernel (see
// classify/sample_kernels.h) so classification inlines into it. Internal to render/.
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>

#include "udvr/classify/fast_tf.h"
#include "udvr/classify/transfer_function.h"
#include "udvr/io/image.h"
#include "udvr/render/batch_kernels.h"
#include "udvr/render/camera.h"
#include "udvr/render/render.h"
#include "udvr/util/fast_math.h"
#include "udvr/util/grid.h"
#include "udvr/util/parallel.h"
#include "udvr/util/random.h"
#include "udvr/util/simd.h"

namespace udvr::detail {

/// Cells per brick edge of the empty-space-skipping table (index space). Coarse bricks: a run
/// through a brick costs ~40 instructions to set up, more than the samples a finer brick would
/// skip on the tangle (64³: 4-cell bricks 117 ms, 16-cell 99 ms, none 94 ms per frame; 256³:
/// 470, 385, 385 ms); empty cells inside a non-empty brick are still not classified (the
/// per-sample cell test), and large empty regions are still jumped.
inline constexpr int kBrickCells = 16;
/// Pixels per tile edge; tiles are the unit of parallel work.
inline constexpr int kTilePixels = 16;

/// Empty-space tables over the model grid's cells. A cell is empty when the hull of its 8
/// corner voxels' supports misses every non-zero-opacity range of the TF, so every sample whose
/// trilinear cell it is classifies to E[α] = 0 and is skipped; a brick (kBrickCells³ cells) is
/// empty when all its cells are, and rays jump over empty bricks whole.
struct SkipTable {
    int dims[3] = {1, 1, 1};    // grid points per axis
    int cells[3] = {1, 1, 1};   // cells per axis (≥ 1)
    int bricks[3] = {1, 1, 1};  // bricks per axis
    // One bit per cell, indexed by the cell's base voxel v (x fastest): bit v % 32 of word
    // v / 32 (a byte per cell would be 8× the cache footprint: 16 MB at 256³).
    std::vector<std::uint32_t> cellEmptyBits;
    std::vector<std::uint8_t> empty;  // per brick

    bool cellEmpty(std::size_t v) const { return isCellEmpty(cellEmptyBits.data(), v); }

    std::size_t index(int bx, int by, int bz) const {
        return (static_cast<std::size_t>(bz) * static_cast<std::size_t>(bricks[1]) +
                static_cast<std::size_t>(by)) *
                   static_cast<std::size_t>(bricks[0]) +
               static_cast<std::size_t>(bx);
    }
};

template <class Kernel>
SkipTable buildSkipTable(const Kernel& kernel, const Grid3& grid,
                         const std::vector<std::pair<double, double>>& ranges) {
    SkipTable t;
    for (int a = 0; a < 3; ++a) {
        t.dims[a] = grid.dims[a];
        t.cells[a] = std::max(grid.dims[a] - 1, 1);
        t.bricks[a] = (t.cells[a] + kBrickCells - 1) / kBrickCells;
    }
    const std::size_t n = grid.pointCount();
    const std::size_t nBricks = static_cast<std::size_t>(t.bricks[0]) * t.bricks[1] * t.bricks[2];
    if (ranges.empty()) {  // the TF is transparent everywhere
        t.cellEmptyBits.assign((n + 31) / 32, ~0u);
        t.empty.assign(nBricks, 1);
        return t;
    }
    // Per-voxel supports, then the hull over each cell's 2×2×2 corners by three in-place passes
    // (x, then y, then z): afterwards lo[v], hi[v] hold the hull of the cell based at voxel v.
    std::vector<float> lo(n), hi(n);
    parallelForChunks(n, 4096, [&](std::size_t b, std::size_t e) {
        for (std::size_t v = b; v < e; ++v) {
            kernel.voxelSupport(v, lo[v], hi[v]);
            if (!(lo[v] <= hi[v])) {  // NaN or inverted: never skip
                lo[v] = -std::numeric_limits<float>::infinity();
                hi[v] = std::numeric_limits<float>::infinity();
            }
        }
    });
    const std::size_t nx = static_cast<std::size_t>(grid.dims[0]);
    const std::size_t ny = static_cast<std::size_t>(grid.dims[1]);
    const std::size_t nz = static_cast<std::size_t>(grid.dims[2]);
    const std::size_t stride[3] = {1, nx, nx * ny};
    for (int a = 0; a < 3; ++a) {
        if (grid.dims[a] < 2) continue;
        // Rows of x in ascending order; v + stride[a] is read before it is overwritten.
        const auto pass = [&](std::size_t b, std::size_t e) {
            for (std::size_t line = b; line < e; ++line) {
                const std::size_t j = line % ny, k = line / ny;
                if (a == 1 && j + 1 >= ny) continue;  // last plane: no neighbour
                if (a == 2 && k + 1 >= nz) continue;
                const std::size_t v0 = line * nx, m = nx - (a == 0 ? 1 : 0);
                for (std::size_t i = 0; i < m; ++i) {
                    const std::size_t v = v0 + i;
                    lo[v] = std::min(lo[v], lo[v + stride[a]]);
                    hi[v] = std::max(hi[v], hi[v + stride[a]]);
                }
            }
        };
        if (a == 2) {
            pass(0, ny * nz);  // z reads the next plane: keep planes in order
        } else {
            parallelForChunks(ny * nz, 64, pass);
        }
    }
    t.cellEmptyBits.assign((n + 31) / 32, 0u);
    parallelForChunks((n + 31) / 32, 128, [&](std::size_t wb, std::size_t we) {
        for (std::size_t v = wb * 32; v < std::min(we * 32, n); ++v) {
            // A float trilinear blend may round an ulp past its corners: pad the hull.
            const double l0 = lo[v], h0 = hi[v];
            const double pad = 1e-6 * (std::abs(l0) + std::abs(h0) + 1e-30);
            const double l = l0 - pad, h = h0 + pad;
            bool hit = false;
            for (const auto& r : ranges) hit = hit || !(h < r.first || l > r.second);
            if (!hit) t.cellEmptyBits[v >> 5] |= 1u << (v & 31u);
        }
    });
    t.empty.assign(nBricks, 1);
    const std::size_t bx = static_cast<std::size_t>(t.bricks[0]);
    const std::size_t by = static_cast<std::size_t>(t.bricks[1]);
    parallelForChunks(nBricks, 16, [&](std::size_t b, std::size_t e) {
        for (std::size_t br = b; br < e; ++br) {
            const int c[3] = {static_cast<int>(br % bx), static_cast<int>((br / bx) % by),
                              static_cast<int>(br / (bx * by))};
            int c0[3], c1[3];
            for (int a = 0; a < 3; ++a) {
                c0[a] = c[a] * kBrickCells;
                c1[a] = std::min(c0[a] + kBrickCells, t.cells[a]);
            }
            bool allEmpty = true;
            for (int z = c0[2]; z < c1[2] && allEmpty; ++z)
                for (int y = c0[1]; y < c1[1] && allEmpty; ++y)
                    for (int x = c0[0]; x < c1[0] && allEmpty; ++x)
                        allEmpty = t.cellEmpty(grid.index(x, y, z));
            t.empty[br] = allEmpty ? 1 : 0;
        }
    });
    return t;
}

/// Frame-constant parameters of the ray loop.
struct MarchParams {
    CameraFrame frame;
    std::array<double, 6> bounds{};  // world box the rays sample (full-resolution bounds)
    Grid3 grid;                      // the model's own grid: world → index space
    double step = 0.0;               // Δ, world units
    float opacityExponent = 1.f;     // Δ / u
    float earlyExit = 0.99f;
    std::array<float, 3> background{1.f, 1.f, 1.f};
    bool skipEmpty = true;
    bool jitter = false;
    std::uint64_t jitterSeed = 0;
};

/// Counters summed over all rays of a frame.
struct MarchCounters {
    std::atomic<std::uint64_t> samples{0};
    std::atomic<std::uint64_t> skipped{0};
};

/// α' = 1 − (1 − α)^(Δ/u) (SPEC §5 opacity correction) and the colour scale α'/α, with the
/// common exponents exact and cheap: 1 (Δ = u) and ½ (the default Δ = spacing/2, u = spacing).
/// Other exponents use a table over α of g(α) = α' and h(α) = α'/α with linear interpolation
/// (VTK bakes the correction into its TF table the same way), built per frame: every interval
/// whose interpolation error (checked at three interior points in double, times 2) could exceed
/// kTableError falls back to powf; that happens only near α = 1, where (1 − α)^e is steep.
struct OpacityCorrection {
    enum Mode { kIdentity, kHalf, kGeneral } mode = kGeneral;
    float exponent = 1.f;
    static constexpr int kEntries = 4096;
    static constexpr double kTableError = 1e-6;
    struct Entry {
        float g0, dg, h0, dh;  // g = g0 + dg·f, h = h0 + dh·f on [i/N, (i+1)/N]; NaN g0: exact
    };
    std::vector<Entry> table;

    explicit OpacityCorrection(float e) : exponent(e) {
        mode = e == 1.f ? kIdentity : (e == 0.5f ? kHalf : kGeneral);
        if (mode != kGeneral) return;
        const double ed = e;
        const auto g = [&](double a) { return 1.0 - std::pow(1.0 - a, ed); };
        const auto h = [&](double a) { return a > 0.0 ? g(a) / a : ed; };  // h(0) = e
        table.resize(kEntries);
        for (int i = 0; i < kEntries; ++i) {
            const double a0 = static_cast<double>(i) / kEntries,
                         a1 = static_cast<double>(i + 1) / kEntries;
            Entry& en = table[static_cast<std::size_t>(i)];
            const double g0 = g(a0), g1 = g(a1), h0 = h(a0), h1 = h(a1);
            double err = 0.0;
            for (double t : {0.25, 0.5, 0.75}) {
                const double a = a0 + t * (a1 - a0);
                err = std::max(err, std::abs(g0 + t * (g1 - g0) - g(a)));
                err = std::max(err, std::abs(h0 + t * (h1 - h0) - h(a)));
            }
            if (!(2.0 * err <= kTableError)) {
                en = Entry{std::numeric_limits<float>::quiet_NaN(), 0.f, 0.f, 0.f};
                continue;
            }
            en = Entry{static_cast<float>(g0), static_cast<float>(g1 - g0), static_cast<float>(h0),
                       static_cast<float>(h1 - h0)};
        }
    }
    /// α' and α'/α for an expected opacity a ∈ (0, 1].
    void operator()(float a, float& alpha, float& scale) const {
        if (mode == kIdentity) {
            alpha = a;
            scale = 1.f;
            return;
        }
        if (mode == kHalf) {
            alpha = 1.f - std::sqrt(1.f - a);
            scale = alpha / a;
            return;
        }
        const float u = a * static_cast<float>(kEntries);
        const int i = std::min(static_cast<int>(u), kEntries - 1);
        const Entry& en = table[static_cast<std::size_t>(i)];
        if (en.g0 == en.g0) {
            const float f = u - static_cast<float>(i);
            alpha = en.g0 + f * en.dg;
            scale = en.h0 + f * en.dh;
            return;
        }
        alpha = 1.f - std::pow(1.f - a, exponent);
        scale = alpha / a;
    }

#if UDVR_HAVE_AVX512
    /// α' and the transmittance factor 1 − α' = (1 − a)^e of 16 opacities a ∈ [0, 1], without
    /// cancellation for small a: ln(1 − a) = 2·atanh(s) with s = −a/(2 − a) for a ≤ ¼ (no 1 − a
    /// formed), α' = −expm1(e·ln(1 − a)) from the series of e^y − 1 near 0. Error ≈ 1e−7
    /// relative in α' (the scalar table allows 1e−6 absolute).
    void apply16(__m512 a, __m512& alpha, __m512& keep, __mmask16 live = 0xFFFF) const {
        const __m512 one = _mm512_set1_ps(1.f);
        if (mode == kIdentity) {
            alpha = a;
            keep = _mm512_sub_ps(one, a);
            return;
        }
        if (mode == kHalf) {  // 1 − √(1 − a) = a / (1 + √(1 − a))
            keep = _mm512_sqrt_ps(_mm512_sub_ps(one, a));
            alpha = _mm512_div_ps(a, _mm512_add_ps(one, keep));
            return;
        }
        const __m512 x = _mm512_sub_ps(one, a);
        const __mmask16 small = _mm512_cmp_ps_mask(a, _mm512_set1_ps(0.25f), _CMP_LE_OQ);
        const __mmask16 opaque = _mm512_cmp_ps_mask(a, one, _CMP_GE_OQ);
        // ln x: for x = 1 − a ≥ ¾ as 2·atanh(−a/(2 − a)), otherwise logPositive (x is normal
        // for a < 1; the opaque lanes take x = 1 and are set below).
        // Lanes outside `live` do not matter: each branch runs only if a live lane needs it.
        const auto needed = [&](__mmask16 m) { return (m & live) != 0; };
        __m512 lnx = logOfAtanhArg(
            _mm512_div_ps(_mm512_sub_ps(_mm512_setzero_ps(), a), _mm512_add_ps(one, x)));
        if (needed(static_cast<__mmask16>(~small)))
            lnx = _mm512_mask_mov_ps(logPositive(_mm512_mask_mov_ps(x, opaque, one)), small, lnx);
        const __m512 y = _mm512_mul_ps(lnx, _mm512_set1_ps(exponent));  // ≤ 0
        // e^y − 1: y·expm1OverX(y) for |y| ≤ ln2/2 (no cancellation), else e^y − 1.
        const __mmask16 near0 = _mm512_cmp_ps_mask(y, _mm512_set1_ps(-0.34657359f), _CMP_GE_OQ);
        keep = one;
        __m512 em1 = _mm512_setzero_ps();
        if (needed(static_cast<__mmask16>(~near0))) {
            keep = expNonPositive(y);
            em1 = _mm512_sub_ps(keep, one);
        }
        if (needed(near0)) em1 = _mm512_mask_mov_ps(em1, near0, _mm512_mul_ps(expm1OverX(y), y));
        alpha = _mm512_mask_mov_ps(_mm512_sub_ps(_mm512_setzero_ps(), em1), opaque, one);
        keep = _mm512_mask_mov_ps(keep, near0, _mm512_add_ps(em1, one));
        keep = _mm512_mask_mov_ps(keep, opaque, _mm512_setzero_ps());
    }
#endif
};

#if UDVR_HAVE_AVX512
/// Front-to-back compositing (SPEC §5) of one ray in batches of 16 samples: the transmittance
/// T = 1 − accumulated α, and colour sums kept per lane (added up once, at the end of the ray).
/// Within a batch T before each sample is T times the prefix product of the earlier samples'
/// (1 − α'), so a batch costs a handful of vector operations instead of a serial chain.
struct BatchCompositor {
    float transmittance = 1.f;
    __m512 sumR = _mm512_setzero_ps(), sumG = _mm512_setzero_ps(), sumB = _mm512_setzero_ps();

    /// Composite the `live` lanes of a batch in lane order: premultiplied colour (pr, pg, pb) and
    /// E[α] before opacity correction. Lanes with E[α] ≤ 0 (or NaN) contribute nothing. Returns
    /// true when the accumulated α passed the early-exit threshold (1 − T > exit); the lanes
    /// after that sample are dropped.
    bool add(__m512 pr, __m512 pg, __m512 pb, __m512 a, __mmask16 live,
             const OpacityCorrection& correct, float exitTransmittance) {
        const __m512 one = _mm512_set1_ps(1.f);
        live &= _mm512_cmp_ps_mask(a, _mm512_setzero_ps(), _CMP_GT_OQ);
        if (!live) return false;
        const __m512 aClamped = _mm512_min_ps(a, one);
        __m512 alpha, keep;
        correct.apply16(aClamped, alpha, keep, live);
        keep = _mm512_mask_mov_ps(one, live, keep);
        const __m512 after = simd::prefixProduct(keep);  // T after lane i, over T
        const __m512 before = simd::shiftUp<1>(after, one);
        const __mmask16 exit =
            _mm512_cmp_ps_mask(_mm512_mul_ps(_mm512_set1_ps(transmittance), after),
                               _mm512_set1_ps(exitTransmittance), _CMP_LT_OQ) &
            live;
        int last = 15;
        if (exit) {
            last = __builtin_ctz(exit);
            live &= static_cast<__mmask16>((2u << last) - 1u);
        }
        // Weight of lane i: T_i · α'_i / a_i (the premultiplied colour carries a_i).
        const __m512 w = _mm512_mul_ps(_mm512_mul_ps(_mm512_set1_ps(transmittance), before),
                                       _mm512_div_ps(alpha, aClamped));
        sumR = _mm512_mask3_fmadd_ps(w, pr, sumR, live);
        sumG = _mm512_mask3_fmadd_ps(w, pg, sumG, live);
        sumB = _mm512_mask3_fmadd_ps(w, pb, sumB, live);
        transmittance *= simd::lane(after, last);
        return exit != 0;
    }
    /// Accumulated (r, g, b) (premultiplied) and α.
    void result(float& r, float& g, float& b, float& a) const {
        float sums[4];
        simd::sum4(sumR, sumG, sumB, _mm512_setzero_ps(), sums);
        r = sums[0];
        g = sums[1];
        b = sums[2];
        a = 1.f - transmittance;
    }
};
#endif

/// Whether the per-sample loop tests each sample's cell before classifying it: worth it when
/// classification costs far more than the test (every kernel but the plain mean field).
template <class Kernel>
inline constexpr bool kCellSkip = !std::is_same_v<Kernel, FastMeanKernel>;

/// Kernels that classify 16 samples at once (load16/finish16 over cells from positions, see
/// FastMeanKernel) when their runtime `batch16()` says so.
template <class Kernel>
inline constexpr bool kHasBatch16 = requires(const Kernel& k) {
    k.batch16();
};

/// Whether marchFrame takes the batched loop for `kernel` (AVX-512 and the kernel's batch16()).
template <class Kernel>
bool batchable16(const Kernel& kernel) {
#if UDVR_HAVE_AVX512
    if constexpr (kHasBatch16<Kernel>) return kernel.batch16();
#endif
    (void)kernel;
    return false;
}

/// One ray's samples in the model's index space: sample s = 0 … n−1 at a + s·b. Positions are
/// not accumulated, so a sample's position does not depend on which samples were skipped.
struct RaySamples {
    float a[3] = {0, 0, 0}, b[3] = {0, 0, 0};
    float invB[3] = {0, 0, 0};  // 1/b per axis (0 where b = 0)
    std::int64_t n = 0;
};

/// The samples of pixel (px, py) (SPEC §5): the first at t_entry + offset·Δ (offset ½, or the
/// pixel's jitter in [0, 1)), then every Δ while (s + offset)Δ ≤ t_exit − t_entry.
inline RaySamples raySamples(const MarchParams& p, int px, int py) {
    RaySamples r;
    std::array<double, 3> o, d;
    p.frame.ray(px, py, o, d);
    double offset = 0.5;
    if (p.jitter) {
        CounterRng rng(p.jitterSeed, 0, static_cast<std::uint64_t>(py) * p.frame.width + px);
        offset = rng.uniform();
    }
    double tNear, tFar;
    if (!intersectBox(p.bounds, o, d, tNear, tFar)) return r;
    if (!p.frame.parallel) tNear = std::max(tNear, 0.0);
    const double span = (tFar - tNear) / p.step;  // path length in steps
    if (!(span >= offset)) return r;
    r.n = static_cast<std::int64_t>(std::floor(span - offset)) + 1;
    const double t = tNear + offset * p.step;
    for (int ax = 0; ax < 3; ++ax) {
        const double inv = 1.0 / p.grid.spacing[ax];
        r.a[ax] = static_cast<float>((o[ax] + t * d[ax] - p.grid.origin[ax]) * inv);
        r.b[ax] = static_cast<float>(p.step * d[ax] * inv);
        r.invB[ax] = r.b[ax] != 0.f ? 1.f / r.b[ax] : 0.f;
    }
    return r;
}

/// Empty-space skipping at sample s: when s lies in an empty brick, move s past it, count the
/// jumped samples in `skipped` and return true; else return false with `end` = one past the
/// last sample certainly inside s's brick.
inline bool skipEmptyBrick(const SkipTable& bricks, const RaySamples& r, std::int64_t& s,
                           std::int64_t& end, std::uint64_t& skipped) {
    // The brick of sample s (by its clamped trilinear cell) and the sample parameter where the
    // ray leaves that brick's slab.
    const float sf = static_cast<float>(s);
    int br[3];
    float sExit = std::numeric_limits<float>::infinity();
    for (int ax = 0; ax < 3; ++ax) {
        const float v = r.a[ax] + sf * r.b[ax];
        const float vc = std::clamp(v, 0.f, static_cast<float>(bricks.cells[ax]));
        const int cell = std::min(static_cast<int>(vc), bricks.cells[ax] - 1);
        br[ax] = cell / kBrickCells;
        float edge;
        if (r.b[ax] > 0.f) {
            if (br[ax] == bricks.bricks[ax] - 1) continue;
            edge = static_cast<float>((br[ax] + 1) * kBrickCells);
        } else if (r.b[ax] < 0.f) {
            if (br[ax] == 0) continue;
            edge = static_cast<float>(br[ax] * kBrickCells);
        } else {
            continue;
        }
        sExit = std::min(sExit, (edge - r.a[ax]) * r.invB[ax]);
    }
    sExit = std::min(sExit, static_cast<float>(r.n));
    // Whole samples certainly inside the brick end at ⌊sExit⌋ (the one at ⌊sExit⌋ is
    // re-checked when we land on it).
    const std::int64_t last = static_cast<std::int64_t>(std::floor(std::max(sExit, 0.f)));
    if (bricks.empty[bricks.index(br[0], br[1], br[2])]) {
        const std::int64_t next = std::max(s + 1, last);
        skipped += static_cast<std::uint64_t>(next - s);
        s = next;
        return true;
    }
    end = std::min(r.n, std::max(s + 1, last + 1));
    return false;
}

/// skipEmptyBrick over a run of empty bricks: from the brick of sample s, walk brick to brick
/// while they are empty (a 3-D DDA in sample units: per axis the next slab crossing, advanced
/// by kBrickCells/|b| per brick), then move s to the last whole sample before the first
/// non-empty brick (or to n). Returns whether s moved. The batches after the jump test every
/// cell, and a crossing is off by far less than a sample, so rounding never skips a visible
/// sample.
inline bool skipEmptyBricks(const SkipTable& bricks, const RaySamples& r, std::int64_t& s,
                            std::uint64_t& skipped) {
    const float inf = std::numeric_limits<float>::infinity();
    const float sf = static_cast<float>(s);
    int br[3], dir[3];
    float next[3], delta[3];
    for (int ax = 0; ax < 3; ++ax) {
        const float v = r.a[ax] + sf * r.b[ax];
        const float vc = std::clamp(v, 0.f, static_cast<float>(bricks.cells[ax]));
        const int cell = std::min(static_cast<int>(vc), bricks.cells[ax] - 1);
        br[ax] = cell / kBrickCells;
        next[ax] = delta[ax] = inf;
        dir[ax] = 0;
        if (r.b[ax] > 0.f && br[ax] != bricks.bricks[ax] - 1) {
            next[ax] = (static_cast<float>((br[ax] + 1) * kBrickCells) - r.a[ax]) * r.invB[ax];
            delta[ax] = static_cast<float>(kBrickCells) * r.invB[ax];
            dir[ax] = 1;
        } else if (r.b[ax] < 0.f && br[ax] != 0) {
            next[ax] = (static_cast<float>(br[ax] * kBrickCells) - r.a[ax]) * r.invB[ax];
            delta[ax] = -static_cast<float>(kBrickCells) * r.invB[ax];
            dir[ax] = -1;
        }
    }
    const float nf = static_cast<float>(r.n);
    float exitAt = -1.f;  // where the ray leaves the last empty brick walked
    while (bricks.empty[bricks.index(br[0], br[1], br[2])]) {
        const int ax =
            next[0] <= next[1] ? (next[0] <= next[2] ? 0 : 2) : (next[1] <= next[2] ? 1 : 2);
        exitAt = std::min(next[ax], nf);
        if (!(next[ax] < nf)) break;  // the ray ends in this brick
        br[ax] += dir[ax];
        const bool last = dir[ax] > 0 ? br[ax] == bricks.bricks[ax] - 1 : br[ax] == 0;
        next[ax] = last ? inf : next[ax] + delta[ax];
    }
    if (exitAt < 0.f) return false;  // s's own brick is not empty
    // ⌊exitAt⌋; NaN (a denormal b times a start on a slab: 0·∞) lands on the next sample.
    const std::int64_t target =
        std::max(s + 1, static_cast<std::int64_t>(exitAt > 0.f ? exitAt : 0.f));
    skipped += static_cast<std::uint64_t>(target - s);
    s = target;
    return true;
}

/// Straight RGB over the background and the accumulated α (SPEC §5) from premultiplied sums.
inline void writePixel(float* out, float r, float g, float b, float a, const MarchParams& p) {
    const float rest = 1.f - a;
    out[0] = r + rest * p.background[0];
    out[1] = g + rest * p.background[1];
    out[2] = b + rest * p.background[2];
    out[3] = a;
}

/// Calls f(x0, y0, x1, y1) for the tiles of the image, tiles spread over the cores; f returns
/// the (classified, skipped) sample counts it saw, summed into `counters`.
template <class F>
void forEachTile(int width, int height, MarchCounters& counters, const F& f) {
    const int tilesX = (width + kTilePixels - 1) / kTilePixels;
    const int tilesY = (height + kTilePixels - 1) / kTilePixels;
    parallelForChunks(
        static_cast<std::size_t>(tilesX) * tilesY, 1, [&](std::size_t t0, std::size_t t1) {
            std::uint64_t samples = 0, skipped = 0;
            for (std::size_t tile = t0; tile < t1; ++tile) {
                const int x0 =
                    static_cast<int>(tile % static_cast<std::size_t>(tilesX)) * kTilePixels;
                const int y0 =
                    static_cast<int>(tile / static_cast<std::size_t>(tilesX)) * kTilePixels;
                f(x0, y0, std::min(x0 + kTilePixels, width), std::min(y0 + kTilePixels, height),
                  samples, skipped);
            }
            counters.samples += samples;
            counters.skipped += skipped;
        });
}

#if UDVR_HAVE_AVX512
/// A ray in flight in marchFrame16.
template <class Kernel>
struct Ray16 {
    RaySamples r;
    std::int64_t s = 0;      // next sample
    bool checkBrick = true;  // test s's brick before the next batch
    bool pending = false;    // a loaded batch waits for finish16 and compositing
    __mmask16 pendingLive = 0;
    typename Kernel::Loaded16 loaded{};
    BatchCompositor comp;
    float* out = nullptr;
};

/// One step of a ray in marchFrame16, software-pipelined: classify and composite the batch
/// loaded by the previous step (finish16, BatchCompositor), then either test the brick at the
/// next sample (jumping an empty brick) or load the next batch of 16 samples: positions, cells
/// and the per-cell emptiness test at once, then load16. A batch whose cells are all empty hands
/// back to the brick test; other batches run on across brick borders. Returns true when the
/// ray is finished.
template <class Kernel>
bool step16(const Kernel& kernel, const SkipTable& bricks, bool skipEmpty, Ray16<Kernel>& ray,
            const OpacityCorrection& correct, float exitTransmittance, std::uint64_t& samples,
            std::uint64_t& skipped) {
    const RaySamples& r = ray.r;
    if (ray.pending) {
        ray.pending = false;
        __m512 cr, cg, cb, ca;
        kernel.finish16(ray.loaded, cr, cg, cb, ca);
        if (ray.comp.add(cr, cg, cb, ca, ray.pendingLive, correct, exitTransmittance)) return true;
    }
    if (ray.s >= r.n) return true;
    if (skipEmpty && ray.checkBrick) {
        // Jump the empty bricks ahead, then go on with a batch in the same step.
        if (skipEmptyBricks(bricks, r, ray.s, skipped) && ray.s >= r.n) return true;
        ray.checkBrick = false;
    }
    const __m512 zero = _mm512_setzero_ps();
    const __m512 sf = _mm512_add_ps(_mm512_set1_ps(static_cast<float>(ray.s)),
                                    _mm512_setr_ps(0.f, 1.f, 2.f, 3.f, 4.f, 5.f, 6.f, 7.f, 8.f, 9.f,
                                                   10.f, 11.f, 12.f, 13.f, 14.f, 15.f));
    const __m512i strideY = _mm512_set1_epi32(kernel.stride32[1]);
    const __m512i strideZ = _mm512_set1_epi32(kernel.stride32[2]);
    // Cells as FastMeanKernel::cellsAt computes them, at sample parameters t.
    const auto cellsAt = [&](__m512 t, __m512* frac) {
        __m512i i[3];
        for (int ax = 0; ax < 3; ++ax) {
            const __m512 x = _mm512_min_ps(
                _mm512_max_ps(_mm512_fmadd_ps(t, _mm512_set1_ps(r.b[ax]), _mm512_set1_ps(r.a[ax])),
                              zero),
                _mm512_set1_ps(kernel.maxIndex[ax]));
            i[ax] = _mm512_min_epi32(_mm512_cvttps_epi32(x), _mm512_set1_epi32(kernel.maxBase[ax]));
            if (frac) frac[ax] = _mm512_sub_ps(x, _mm512_cvtepi32_ps(i[ax]));
        }
        return _mm512_add_epi32(i[0], _mm512_add_epi32(_mm512_mullo_epi32(i[1], strideY),
                                                       _mm512_mullo_epi32(i[2], strideZ)));
    };
    const int m = static_cast<int>(std::min<std::int64_t>(16, r.n - ray.s));
    const __mmask16 lanes = static_cast<__mmask16>(m == 16 ? 0xFFFFu : (1u << m) - 1u);
    __m512 f[3];
    const __m512i base = cellsAt(sf, f);
    __mmask16 live = lanes;
    if (kernel.cellEmpty) {
        const __m512i words = _mm512_mask_i32gather_epi32(
            _mm512_setzero_si512(), lanes, _mm512_srli_epi32(base, 5), kernel.cellEmpty, 4);
        const __m512i bit =
            _mm512_sllv_epi32(_mm512_set1_epi32(1), _mm512_and_si512(base, _mm512_set1_epi32(31)));
        live &= static_cast<__mmask16>(~_mm512_test_epi32_mask(words, bit));
    }
    const int nLive = __builtin_popcount(live);
    skipped += static_cast<std::uint64_t>(m - nLive);
    ray.s += m;
    if (!live) {  // empty space: back to the brick test
        ray.checkBrick = true;
        return ray.s >= r.n;
    }
    samples += static_cast<std::uint64_t>(nLive);
    // Prefetch the cells two batches ahead (lanes 0, 8, 15; the four x-rows of each).
    alignas(64) int ahead[16];
    _mm512_store_si512(ahead, cellsAt(_mm512_add_ps(sf, _mm512_set1_ps(32.f)), nullptr));
    for (int l : {0, 8, 15}) kernel.prefetchCell(ahead[l]);
    ray.loaded = kernel.load16(base, f[0], f[1], f[2], Kernel::kLoadDeadLanes ? lanes : live);
    ray.pendingLive = live;
    ray.pending = true;
    return false;
}

/// marchFrame for kernels with load16/finish16: in each tile kRaysInFlight neighbouring rays
/// advance in turns, a step each, so the loads of one ray's batch overlap the classification
/// and compositing of the others'.
template <class Kernel>
void marchFrame16(const Kernel& kernel, const SkipTable& bricks, const MarchParams& p,
                  ImageRgba& image, MarchCounters& counters) {
    constexpr int kRaysInFlight = 4;
    const OpacityCorrection correct(p.opacityExponent);
    const float exitTransmittance = 1.f - p.earlyExit;
    forEachTile(
        p.frame.width, p.frame.height, counters,
        [&](int x0, int y0, int x1, int y1, std::uint64_t& samples, std::uint64_t& skipped) {
            const int w = x1 - x0, count = w * (y1 - y0);
            int next = 0;  // next pixel of the tile, row by row
            // Start the next ray with samples in `ray`; pixels without write the
            // background. False when the tile has no more pixels.
            const auto start = [&](Ray16<Kernel>& ray) {
                while (next < count) {
                    const int px = x0 + next % w, py = y0 + next / w;
                    ++next;
                    ray = Ray16<Kernel>{};
                    ray.r = raySamples(p, px, py);
                    ray.out = image.pixel(px, py);
                    if (ray.r.n > 0) return true;
                    writePixel(ray.out, 0.f, 0.f, 0.f, 0.f, p);
                }
                return false;
            };
            Ray16<Kernel> rays[kRaysInFlight];
            bool active[kRaysInFlight];
            int inFlight = 0;
            for (int k = 0; k < kRaysInFlight; ++k) inFlight += (active[k] = start(rays[k]));
            while (inFlight > 0) {
                for (int k = 0; k < kRaysInFlight; ++k) {
                    if (!active[k]) continue;
                    Ray16<Kernel>& ray = rays[k];
                    if (!step16(kernel, bricks, p.skipEmpty, ray, correct, exitTransmittance,
                                samples, skipped))
                        continue;
                    float rr, gg, bb, aa;
                    ray.comp.result(rr, gg, bb, aa);
                    writePixel(ray.out, rr, gg, bb, aa, p);
                    if (!(active[k] = start(ray))) --inFlight;
                }
            }
        });
}
#endif

/// March every pixel of `image` (already sized) through `kernel`: straight RGB over the
/// background and the accumulated α. Kernels with load16/finish16 go to marchFrame16; the others
/// classify and composite sample by sample.
template <class Kernel>
void marchFrame(const Kernel& kernel, const SkipTable& bricks, const MarchParams& p,
                ImageRgba& image, MarchCounters& counters) {
#if UDVR_HAVE_AVX512
    if constexpr (kHasBatch16<Kernel>) {
        if (batchable16(kernel)) {
            marchFrame16(kernel, bricks, p, image, counters);
            return;
        }
    }
#endif
    const OpacityCorrection correct(p.opacityExponent);
    const std::size_t cellStride[3] = {
        1, static_cast<std::size_t>(bricks.dims[0]),
        static_cast<std::size_t>(bricks.dims[0]) * static_cast<std::size_t>(bricks.dims[1])};
    forEachTile(
        p.frame.width, p.frame.height, counters,
        [&](int x0, int y0, int x1, int y1, std::uint64_t& nSamples, std::uint64_t& nSkipped) {
            for (int py = y0; py < y1; ++py)
                for (int px = x0; px < x1; ++px) {
                    float accR = 0.f, accG = 0.f, accB = 0.f, accA = 0.f;
                    // Composite one classified sample front to back (SPEC §5); true once the
                    // accumulated α passes the early-exit threshold.
                    const auto composite = [&](const Rgba& c) {
                        if (!(c.a > 0.f)) return false;  // E[α] = 0 contributes nothing
                        float alpha, scale;
                        correct(std::min(c.a, 1.f), alpha, scale);
                        const float w = (1.f - accA) * scale;
                        accR += w * c.r;
                        accG += w * c.g;
                        accB += w * c.b;
                        accA += (1.f - accA) * alpha;
                        return accA > p.earlyExit;
                    };
                    const RaySamples r = raySamples(p, px, py);
                    const float* a = r.a;
                    const float* b = r.b;
                    const std::int64_t n = r.n;
                    std::int64_t s = 0;
                    bool done = false;
                    while (s < n && !done) {
                        std::int64_t end = n;
                        if (p.skipEmpty && skipEmptyBrick(bricks, r, s, end, nSkipped)) continue;
                        if constexpr (std::is_same_v<Kernel, FastMeanKernel>) {
                            if (kernel.batchable) {
                                // Interpolate kBatch samples at once, then classify and
                                // composite them in order (early exit after each).
                                while (s < end && !done) {
                                    constexpr int kB = FastMeanKernel::kBatch;
                                    alignas(64) float val[kB], fx[kB], fy[kB], fz[kB];
                                    alignas(64) int cell[kB];
                                    kernel.cellsAt(a, b, static_cast<int>(s), cell, fx, fy, fz);
                                    const int m =
                                        static_cast<int>(std::min<std::int64_t>(kB, end - s));
                                    const auto empty = [&](int i) {
                                        return kernel.cellEmpty &&
                                               isCellEmpty(kernel.cellEmpty,
                                                           static_cast<std::size_t>(cell[i]));
                                    };
                                    // All cells empty (common inside non-empty bricks): no
                                    // corner loads at all.
                                    bool any = false;
                                    for (int i = 0; i < m; ++i) any |= !empty(i);
                                    if (!any) {
                                        nSkipped += static_cast<std::uint64_t>(m);
                                        s += m;
                                        continue;
                                    }
                                    kernel.blend(cell, fx, fy, fz, val);
                                    for (int i = 0; i < m; ++i) {
                                        if (empty(i)) {
                                            ++nSkipped;
                                            continue;
                                        }
                                        ++nSamples;
                                        if (composite(kernel.tf->classify(val[i]))) {
                                            done = true;
                                            break;
                                        }
                                    }
                                    s += m;
                                }
                                continue;
                            }
                        }
                        for (; s < end; ++s) {
                            const float sf = static_cast<float>(s);
                            if (kCellSkip<Kernel> && p.skipEmpty) {
                                // Cell of the sample, clamped as trilinearCell does.
                                std::size_t v = 0;
                                for (int ax = 0; ax < 3; ++ax) {
                                    const float x =
                                        std::clamp(a[ax] + sf * b[ax], 0.f,
                                                   static_cast<float>(bricks.cells[ax]));
                                    v += static_cast<std::size_t>(
                                             std::min(static_cast<int>(x), bricks.cells[ax] - 1)) *
                                         cellStride[ax];
                                }
                                if (bricks.cellEmpty(v)) {
                                    ++nSkipped;
                                    continue;
                                }
                            }
                            Rgba c;
                            if constexpr (std::is_same_v<Kernel, FastMeanKernel>) {
                                // The mean kernel tests the cell itself (valueAt).
                                const float v = kernel.valueAt(a[0] + sf * b[0], a[1] + sf * b[1],
                                                               a[2] + sf * b[2]);
                                if (v == FastMeanKernel::kEmptyCell) {
                                    ++nSkipped;
                                    continue;
                                }
                                c = kernel.tf->classify(v);
                            } else {
                                c = kernel.classifyAt(a[0] + sf * b[0], a[1] + sf * b[1],
                                                      a[2] + sf * b[2]);
                            }
                            ++nSamples;
                            if (composite(c)) {
                                done = true;
                                break;
                            }
                        }
                    }
                    writePixel(image.pixel(px, py), accR, accG, accB, accA, p);
                }
        });
}

}  // namespace udvr::detail
