#pragma once
// The ray loop of the CPU ray caster (SPEC §5), generic over the kernel of a model family
// (classify/model_kernels.h): one brick walker, one compositor, one opacity correction. A ray
// advances in batches of 16 samples (lanes::Vf): cells and the per-cell emptiness test for the
// whole batch, then the kernel's load/finish on the live lanes, then compositing with the early
// exit at the exact sample where the accumulated α passes the threshold. Internal to render/.
#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "udvr/classify/model_kernels.h"
#include "udvr/render/camera.h"
#include "udvr/render/image_rgba.h"
#include "udvr/render/render.h"
#include "udvr/util/fast_math.h"
#include "udvr/util/grid.h"
#include "udvr/util/lanes.h"
#include "udvr/util/parallel.h"
#include "udvr/util/progress.h"
#include "udvr/util/random.h"

namespace udvr::detail {

/// Bit v of a per-cell emptiness bit table (SkipTable::cellEmptyBits).
inline bool isCellEmpty(const std::uint32_t* bits, std::size_t v) {
    return ((bits[v >> 5] >> (v & 31u)) & 1u) != 0;
}

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
    bool clip = false;                          // composite only the samples inside clipBox
    std::array<double, 6> clipBox{};            // RenderPiece::box
    const std::atomic<bool>* cancel = nullptr;  // when true, the remaining tiles are left undone
};

/// Counters summed over all rays of a frame.
struct MarchCounters {
    std::atomic<std::uint64_t> samples{0};
    std::atomic<std::uint64_t> skipped{0};
};

/// α' = 1 − (1 − α)^e, e = Δ/u (SPEC §5 opacity correction), and the transmittance factor
/// 1 − α' = (1 − α)^e of 16 opacities α ∈ [0, 1]. Error contract: ≤ 1e−6 relative in α' and
/// ≤ 1e−6 absolute in 1 − α' for every e in [1e−3, 30] (batch test against the power in
/// double). e = 1 and e = ½ (the default Δ = spacing/2, u = spacing) are exact forms; otherwise,
/// without cancellation for small α: ln(1 − α) = 2·atanh(s), s = −α/(2 − α), for α ≤ ¼ (no
/// 1 − α formed), α' = −expm1(e·ln(1 − α)) from the series of e^y − 1 near 0.
struct OpacityCorrection {
    enum Mode { kIdentity, kHalf, kGeneral } mode = kGeneral;
    float exponent = 1.f;

    explicit OpacityCorrection(float e) : exponent(e) {
        mode = e == 1.f ? kIdentity : (e == 0.5f ? kHalf : kGeneral);
    }
    /// α' and 1 − α' of the lanes; lanes outside `live` may hold anything.
    void apply(lanes::Vf a, lanes::Mask live, lanes::Vf& alpha, lanes::Vf& keep) const {
        using lanes::Vf;
        const Vf one = lanes::splat<Vf>(1.f);
        if (mode == kIdentity) {
            alpha = a;
            keep = one - a;
            return;
        }
        if (mode == kHalf) {  // 1 − √(1 − a) = a / (1 + √(1 − a))
            keep = lanes::sqrt(one - a);
            alpha = a / (one + keep);
            return;
        }
        const Vf x = one - a;
        const lanes::Mask small = a <= 0.25f;
        const lanes::Mask opaque = a >= 1.f;
        // ln x: for x = 1 − a ≥ ¾ as 2·atanh(−a/(2 − a)), otherwise logPositive (x is normal
        // for a < 1; the opaque lanes take x = 1 and are set below). Each branch runs only if
        // a live lane needs it.
        Vf lnx = logOfAtanhArg(-a / (one + x));
        if (lanes::anyOf(live & !small))
            lnx = lanes::select(small, lnx, logPositive(lanes::select(opaque, one, x)));
        const Vf y = lnx * exponent;  // ≤ 0
        // e^y − 1: y·expm1OverX(y) for |y| ≤ ln2/2 (no cancellation), else e^y − 1.
        const lanes::Mask near0 = y >= -0.34657359f;
        keep = one;
        Vf em1{};
        if (lanes::anyOf(live & !near0)) {
            keep = expNonPositive(y);
            em1 = keep - one;
        }
        if (lanes::anyOf(live & near0)) em1 = lanes::select(near0, expm1OverX(y) * y, em1);
        alpha = lanes::select(opaque, one, -em1);
        keep = lanes::select(near0, em1 + one, keep);
        keep = lanes::select(opaque, Vf{}, keep);
    }
};

/// Front-to-back compositing (SPEC §5) of one ray in batches of 16 samples: the transmittance
/// T = 1 − accumulated α, and colour sums kept per lane (added up once, at the end of the ray).
/// Within a batch T before each sample is T times the prefix product of the earlier samples'
/// (1 − α'), so a batch costs a handful of vector operations instead of a serial chain.
struct Compositor {
    float transmittance = 1.f;
    lanes::Vf sumR{}, sumG{}, sumB{};

    /// Composite the `live` lanes of a batch in lane order: premultiplied colour c[0..2] and
    /// E[α] c[3] before opacity correction. Lanes with E[α] ≤ 0 (or NaN) contribute nothing.
    /// Returns true when the accumulated α passed the early-exit threshold (1 − T > exit); the
    /// lanes after that sample are dropped.
    bool add(const lanes::Vf c[4], lanes::Mask live, const OpacityCorrection& correct,
             float exitTransmittance) {
        using lanes::Vf;
        const Vf one = lanes::splat<Vf>(1.f);
        live = live & (c[3] > 0.f);
        if (lanes::noneOf(live)) return false;
        const Vf a = lanes::min(c[3], one);
        Vf alpha, keep;
        correct.apply(a, live, alpha, keep);
        keep = lanes::select(live, keep, one);
        const Vf after = lanes::prefixProduct(keep);  // T after lane i, over T
        const Vf before = lanes::shiftUp<1>(after, one);
        const std::uint32_t exit = lanes::bits(live & (after * transmittance < exitTransmittance));
        int last = lanes::kWidth - 1;
        if (exit) {
            last = std::countr_zero(exit);
            live = live & lanes::firstLanes(last + 1);
        }
        // Weight of lane i: T_i · α'_i / a_i (the premultiplied colour carries a_i).
        const Vf w = lanes::select(live, before * transmittance * (alpha / a), Vf{});
        sumR = lanes::fma(w, c[0], sumR);
        sumG = lanes::fma(w, c[1], sumG);
        sumB = lanes::fma(w, c[2], sumB);
        transmittance *= after[last];
        return exit != 0;
    }
    /// Accumulated (r, g, b) (premultiplied) and α.
    void result(float& r, float& g, float& b, float& a) const {
        r = lanes::sum(sumR);
        g = lanes::sum(sumG);
        b = lanes::sum(sumB);
        a = 1.f - transmittance;
    }
};

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
    double first = 0.0;  // index of the first sample taken
    if (p.clip) {
        // The samples s with t_s = tNear + (s + offset)Δ in [enter, leave) of the piece's box.
        double enter, leave;
        if (!intersectBox(p.clipBox, o, d, enter, leave)) return RaySamples{};
        const double lo = std::max(0.0, std::ceil((enter - tNear) / p.step - offset));
        const double hi =
            std::min(static_cast<double>(r.n), std::ceil((leave - tNear) / p.step - offset));
        if (!(hi > lo)) return RaySamples{};
        first = lo;
        r.n = static_cast<std::int64_t>(hi - lo);
    }
    const double t = tNear + (first + offset) * p.step;
    for (int ax = 0; ax < 3; ++ax) {
        const double inv = 1.0 / p.grid.spacing[ax];
        r.a[ax] = static_cast<float>((o[ax] + t * d[ax] - p.grid.origin[ax]) * inv);
        r.b[ax] = static_cast<float>(p.step * d[ax] * inv);
        r.invB[ax] = r.b[ax] != 0.f ? 1.f / r.b[ax] : 0.f;
    }
    return r;
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
/// the (classified, skipped) sample counts it saw, summed into `counters`. Once `*cancel` is
/// true the remaining tiles are skipped (the caller discards the image; marchFrame also stops
/// the rays of the tile under way, between steps).
template <class F>
void forEachTile(int width, int height, MarchCounters& counters, const F& f,
                 const std::atomic<bool>* cancel = nullptr) {
    const int tilesX = (width + kTilePixels - 1) / kTilePixels;
    const int tilesY = (height + kTilePixels - 1) / kTilePixels;
    // Long frames (costly models, 2D TFs, big images) show a bar after 2 s.
    ProgressBar bar("render", static_cast<std::size_t>(tilesX) * tilesY, 2.0);
    parallelForChunks(
        static_cast<std::size_t>(tilesX) * tilesY, 1, [&](std::size_t t0, std::size_t t1) {
            std::uint64_t samples = 0, skipped = 0;
            for (std::size_t tile = t0; tile < t1; ++tile) {
                if (cancel && cancel->load(std::memory_order_relaxed)) break;
                const int x0 =
                    static_cast<int>(tile % static_cast<std::size_t>(tilesX)) * kTilePixels;
                const int y0 =
                    static_cast<int>(tile / static_cast<std::size_t>(tilesX)) * kTilePixels;
                f(x0, y0, std::min(x0 + kTilePixels, width), std::min(y0 + kTilePixels, height),
                  samples, skipped);
                bar.advance();
            }
            counters.samples += samples;
            counters.skipped += skipped;
        });
}

/// A ray in flight in marchFrame.
template <class Kernel>
struct RayInFlight {
    RaySamples r;
    std::int64_t s = 0;      // next sample
    bool checkBrick = true;  // test s's brick before the next batch
    bool pending = false;    // a loaded batch waits for finish and compositing
    lanes::Mask pendingLive{};
    typename Kernel::template Loaded<lanes::Vf> loaded{};
    Compositor comp;
    float* out = nullptr;

    /// Start over on samples r writing to out, in place: assigning a fresh RayInFlight copied
    /// a stack temporary whose 64-byte reloads missed store forwarding (~4 % of a mean frame).
    void restart(const RaySamples& samples, float* pixel) {
        r = samples;
        s = 0;
        checkBrick = true;
        pending = false;
        comp = Compositor{};
        out = pixel;
    }
};

/// One step of a ray, software-pipelined: classify and composite the batch loaded by the
/// previous step, then either walk the empty bricks at the next sample or load the next batch
/// of 16 samples: positions, cells and the per-cell emptiness test at once, then the kernel's
/// load. A batch whose cells are all empty hands back to the brick walk; other batches run on
/// across brick borders. Returns true when the ray is finished.
template <class Kernel>
UDVR_FLATTEN bool stepRay(const Kernel& kernel, const SkipTable& bricks,
                          const std::uint32_t* cellEmpty, bool skipEmpty, RayInFlight<Kernel>& ray,
                          const OpacityCorrection& correct, float exitTransmittance,
                          std::uint64_t& samples, std::uint64_t& skipped) {
    using lanes::Vf;
    const RaySamples& r = ray.r;
    if (ray.pending) {
        ray.pending = false;
        Vf c[4];
        kernel.finish(ray.loaded, c);
        if (ray.comp.add(c, ray.pendingLive, correct, exitTransmittance)) return true;
    }
    if (ray.s >= r.n) return true;
    if (skipEmpty && ray.checkBrick) {
        // Jump the empty bricks ahead, then go on with a batch in the same step.
        if (skipEmptyBricks(bricks, r, ray.s, skipped) && ray.s >= r.n) return true;
        ray.checkBrick = false;
    }
    const Vf sf = lanes::toFloat(lanes::iota()) + static_cast<float>(ray.s);
    const auto cellsAt = [&](Vf t) {
        return cellAt<Vf>(kernel.geometry,
                          lanes::fma(t, lanes::splat<Vf>(r.b[0]), lanes::splat<Vf>(r.a[0])),
                          lanes::fma(t, lanes::splat<Vf>(r.b[1]), lanes::splat<Vf>(r.a[1])),
                          lanes::fma(t, lanes::splat<Vf>(r.b[2]), lanes::splat<Vf>(r.a[2])));
    };
    const int m = static_cast<int>(std::min<std::int64_t>(lanes::kWidth, r.n - ray.s));
    const lanes::Mask inRay = lanes::firstLanes(m);
    const Cell<Vf> cell = cellsAt(sf);
    lanes::Mask live = inRay;
    if (cellEmpty) live = live & !lanes::testBits(cellEmpty, cell.base, inRay);
    const int nLive = std::popcount(lanes::bits(live));
    skipped += static_cast<std::uint64_t>(m - nLive);
    ray.s += m;
    if (nLive == 0) {  // empty space: back to the brick walk
        ray.checkBrick = true;
        return ray.s >= r.n;
    }
    samples += static_cast<std::uint64_t>(nLive);
    // Prefetch the cells two batches ahead (first, middle and last lane).
    const Cell<Vf> ahead = cellsAt(sf + static_cast<float>(2 * lanes::kWidth));
    for (int l : {0, lanes::kWidth / 2, lanes::kWidth - 1}) kernel.prefetch(ahead.base[l]);
    ray.loaded = kernel.template load<Vf>(cell, Kernel::kLoadDeadLanes ? inRay : live);
    ray.pendingLive = live;
    ray.pending = true;
    return false;
}

/// March every pixel of `image` (already sized) through `kernel`: straight RGB over the
/// background and the accumulated α. In each tile kRaysInFlight neighbouring rays advance in
/// turns, a step each, so the loads of one ray's batch overlap the classification and
/// compositing of the others'. `cellEmpty`: the per-cell emptiness bits, or null.
template <class Kernel>
void marchFrame(const Kernel& kernel, const SkipTable& bricks, const std::uint32_t* cellEmpty,
                const MarchParams& p, ImageRgba& image, MarchCounters& counters) {
    UDVR_CHECK_MSG(kernel.geometry.fitsInt32, "the ray loop needs 32-bit voxel indices");
    constexpr int kRaysInFlight = 4;
    const OpacityCorrection correct(p.opacityExponent);
    const float exitTransmittance = 1.f - p.earlyExit;
    forEachTile(
        p.frame.width, p.frame.height, counters,
        [&](int x0, int y0, int x1, int y1, std::uint64_t& samples, std::uint64_t& skipped) {
            const int w = x1 - x0, count = w * (y1 - y0);
            int next = 0;  // next pixel of the tile, row by row
            // Start the next ray with samples in `ray`; pixels without write the background.
            // False when the tile has no more pixels.
            const auto start = [&](RayInFlight<Kernel>& ray) {
                while (next < count) {
                    const int px = x0 + next % w, py = y0 + next / w;
                    ++next;
                    ray.restart(raySamples(p, px, py), image.pixel(px, py));
                    if (ray.r.n > 0) return true;
                    writePixel(ray.out, 0.f, 0.f, 0.f, 0.f, p);
                }
                return false;
            };
            RayInFlight<Kernel> rays[kRaysInFlight];
            bool active[kRaysInFlight];
            int inFlight = 0;
            for (int k = 0; k < kRaysInFlight; ++k) inFlight += (active[k] = start(rays[k]));
            while (inFlight > 0) {
                for (int k = 0; k < kRaysInFlight; ++k) {
                    if (!active[k]) continue;
                    // A costly 2D kernel takes up to 60 ms a sample: cancelled, the rays under
                    // way stop too, between steps.
                    if (p.cancel && p.cancel->load(std::memory_order_relaxed)) return;
                    RayInFlight<Kernel>& ray = rays[k];
                    if (!stepRay(kernel, bricks, cellEmpty, p.skipEmpty, ray, correct,
                                 exitTransmittance, samples, skipped))
                        continue;
                    float rr, gg, bb, aa;
                    ray.comp.result(rr, gg, bb, aa);
                    writePixel(ray.out, rr, gg, bb, aa, p);
                    if (!(active[k] = start(ray))) --inFlight;
                }
            }
        },
        p.cancel);
}

}  // namespace udvr::detail
