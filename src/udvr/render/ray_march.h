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

#include "udvr/classify/transfer_function.h"
#include "udvr/io/image.h"
#include "udvr/render/camera.h"
#include "udvr/render/fast_tf.h"
#include "udvr/render/render.h"
#include "udvr/util/grid.h"
#include "udvr/util/parallel.h"
#include "udvr/util/random.h"

namespace udvr::detail {

/// Cells per brick edge of the empty-space-skipping table (index space). Coarse bricks: a run
/// through a brick costs ~40 instructions to set up, more than the samples a finer brick would
/// skip on the tangle (64³: 4-cell bricks 117 ms, 16-cell 99 ms, none 94 ms per frame; 256³:
/// 470, 385, 385 ms); empty cells inside a non-empty brick are still not classified (the
/// per-sample cell test), and large empty regions are still jumped.
inline constexpr int kBrickCells = 16;
/// Pixels per tile edge; tiles are the unit of parallel work.
inline constexpr int kTilePixels = 16;

/// Mean field with the exact fast TF: TF(trilinear(values)), the kernel of `mean`, of plain
/// fields (ground truth) and of each gmm-mc realization.
struct FastMeanKernel {
    const float* values = nullptr;  // one value per grid point, x fastest
    const FastTransferFunction* tf = nullptr;
    float maxIndex[3] = {0, 0, 0};  // dims − 1: index-space clamp (SPEC §3 clamps into the grid)
    int maxBase[3] = {0, 0, 0};     // last cell's base index: max(dims − 2, 0)
    std::size_t stride[3] = {0, 0, 0};  // linear stride per axis
    std::size_t next[3] = {0, 0, 0};    // offset of the +1 neighbour (0 on a 1-point axis)
    // Per-cell emptiness (SkipTable::cellEmpty) or null: the test costs one byte load here,
    // where the cell's base index is computed anyway.
    const std::uint8_t* cellEmpty = nullptr;
    /// valueAt()'s result for a sample in an empty cell: below every value, never classified.
    static constexpr float kEmptyCell = -std::numeric_limits<float>::infinity();

    FastMeanKernel(const Grid3& grid, const float* v, const FastTransferFunction* t)
        : values(v), tf(t) {
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
        if (cellEmpty && cellEmpty[base]) return kEmptyCell;  // E[α] = 0 in the whole cell
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
    /// Whether every voxel index fits an int (the batched loops' 32-bit indices); else valueAt per
    /// sample.
    bool batchable = false;
    int stride32[3] = {0, 0, 0};
    int next32[3] = {0, 0, 0};

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
};

/// Empty-space tables over the model grid's cells. A cell is empty when the hull of its 8
/// corner voxels' supports misses every non-zero-opacity range of the TF, so every sample whose
/// trilinear cell it is classifies to E[α] = 0 and is skipped; a brick (kBrickCells³ cells) is
/// empty when all its cells are, and rays jump over empty bricks whole.
struct SkipTable {
    int dims[3] = {1, 1, 1};              // grid points per axis
    int cells[3] = {1, 1, 1};             // cells per axis (≥ 1)
    int bricks[3] = {1, 1, 1};            // bricks per axis
    std::vector<std::uint8_t> cellEmpty;  // indexed by the cell's base voxel (x fastest)
    std::vector<std::uint8_t> empty;      // per brick

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
        t.cellEmpty.assign(n, 1);
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
    t.cellEmpty.assign(n, 0);
    parallelForChunks(n, 4096, [&](std::size_t b, std::size_t e) {
        for (std::size_t v = b; v < e; ++v) {
            // A float trilinear blend may round an ulp past its corners: pad the hull.
            const double l0 = lo[v], h0 = hi[v];
            const double pad = 1e-6 * (std::abs(l0) + std::abs(h0) + 1e-30);
            const double l = l0 - pad, h = h0 + pad;
            bool hit = false;
            for (const auto& r : ranges) hit = hit || !(h < r.first || l > r.second);
            t.cellEmpty[v] = hit ? 0 : 1;
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
                        allEmpty = t.cellEmpty[grid.index(x, y, z)] != 0;
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
};

/// March every pixel of `image` (already sized) through `kernel`. Writes straight RGB over the
/// background and the accumulated α.
/// Whether the ray loop tests each sample's cell before classifying it: worth it when
/// classification costs far more than the test (every kernel but the plain mean field).
template <class Kernel>
inline constexpr bool kCellSkip = !std::is_same_v<Kernel, FastMeanKernel>;

template <class Kernel>
void marchFrame(const Kernel& kernel, const SkipTable& bricks, const MarchParams& p,
                ImageRgba& image, MarchCounters& counters) {
    const int width = p.frame.width, height = p.frame.height;
    const int tilesX = (width + kTilePixels - 1) / kTilePixels;
    const int tilesY = (height + kTilePixels - 1) / kTilePixels;
    const OpacityCorrection correct(p.opacityExponent);
    const double step = p.step;
    const std::array<double, 3> invSpacing{1.0 / p.grid.spacing[0], 1.0 / p.grid.spacing[1],
                                           1.0 / p.grid.spacing[2]};
    const float inf = std::numeric_limits<float>::infinity();
    const std::size_t cellStride[3] = {
        1, static_cast<std::size_t>(bricks.dims[0]),
        static_cast<std::size_t>(bricks.dims[0]) * static_cast<std::size_t>(bricks.dims[1])};

    parallelForChunks(
        static_cast<std::size_t>(tilesX) * tilesY, 1, [&](std::size_t t0, std::size_t t1) {
            std::uint64_t nSamples = 0, nSkipped = 0;
            for (std::size_t tile = t0; tile < t1; ++tile) {
                const int tx = static_cast<int>(tile % static_cast<std::size_t>(tilesX));
                const int ty = static_cast<int>(tile / static_cast<std::size_t>(tilesX));
                const int x0 = tx * kTilePixels, y0 = ty * kTilePixels;
                const int x1 = std::min(x0 + kTilePixels, width),
                          y1 = std::min(y0 + kTilePixels, height);
                for (int py = y0; py < y1; ++py)
                    for (int px = x0; px < x1; ++px) {
                        float* out = image.pixel(px, py);
                        float accR = 0.f, accG = 0.f, accB = 0.f, accA = 0.f;
                        // Composite one classified sample front to back (SPEC §5); true once
                        // the accumulated α passes the early-exit threshold.
                        auto composite = [&](const Rgba& c) {
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
                        std::array<double, 3> o, d;
                        p.frame.ray(px, py, o, d);
                        double tNear, tFar;
                        std::int64_t n = 0;   // samples on this ray
                        double offset = 0.5;  // first sample at t_entry + offset·Δ
                        if (p.jitter) {
                            CounterRng rng(p.jitterSeed, 0,
                                           static_cast<std::uint64_t>(py) * width + px);
                            offset = rng.uniform();
                        }
                        if (intersectBox(p.bounds, o, d, tNear, tFar)) {
                            if (!p.frame.parallel) tNear = std::max(tNear, 0.0);
                            const double span = (tFar - tNear) / step;  // path length in steps
                            // Samples s = 0, 1, … with (s + offset)Δ ≤ t_exit − t_entry.
                            if (span >= offset)
                                n = static_cast<std::int64_t>(std::floor(span - offset)) + 1;
                        }
                        if (n > 0) {
                            // Index-space position of sample s: a + s·b (not accumulated, so a
                            // sample's position does not depend on which samples were skipped).
                            float a[3], b[3], invB[3];
                            const double t = tNear + offset * step;
                            for (int ax = 0; ax < 3; ++ax) {
                                a[ax] = static_cast<float>((o[ax] + t * d[ax] - p.grid.origin[ax]) *
                                                           invSpacing[ax]);
                                b[ax] = static_cast<float>(step * d[ax] * invSpacing[ax]);
                                invB[ax] = b[ax] != 0.f ? 1.f / b[ax] : 0.f;
                            }
                            const float nf = static_cast<float>(n);
                            std::int64_t s = 0;
                            bool done = false;
                            while (s < n && !done) {
                                std::int64_t end = n;
                                if (p.skipEmpty) {
                                    // The brick of sample s (by its clamped trilinear cell) and the
                                    // sample parameter where the ray leaves that brick's slab.
                                    const float sf = static_cast<float>(s);
                                    int br[3];
                                    float sExit = inf;
                                    for (int ax = 0; ax < 3; ++ax) {
                                        const float v = a[ax] + sf * b[ax];
                                        const float vc = std::clamp(
                                            v, 0.f, static_cast<float>(bricks.cells[ax]));
                                        const int cell =
                                            std::min(static_cast<int>(vc), bricks.cells[ax] - 1);
                                        br[ax] = cell / kBrickCells;
                                        float edge;
                                        if (b[ax] > 0.f) {
                                            if (br[ax] == bricks.bricks[ax] - 1) continue;
                                            edge = static_cast<float>((br[ax] + 1) * kBrickCells);
                                        } else if (b[ax] < 0.f) {
                                            if (br[ax] == 0) continue;
                                            edge = static_cast<float>(br[ax] * kBrickCells);
                                        } else {
                                            continue;
                                        }
                                        sExit = std::min(sExit, (edge - a[ax]) * invB[ax]);
                                    }
                                    sExit = std::min(sExit, nf);
                                    // Whole samples certainly inside the brick end at ⌊sExit⌋ (the
                                    // one at ⌊sExit⌋ is re-checked when we land on it).
                                    const std::int64_t last =
                                        static_cast<std::int64_t>(std::floor(std::max(sExit, 0.f)));
                                    if (bricks.empty[bricks.index(br[0], br[1], br[2])]) {
                                        const std::int64_t next = std::max(s + 1, last);
                                        nSkipped += static_cast<std::uint64_t>(next - s);
                                        s = next;
                                        continue;
                                    }
                                    end = std::min(n, std::max(s + 1, last + 1));
                                }
                                if constexpr (std::is_same_v<Kernel, FastMeanKernel>) {
                                    if (kernel.batchable) {
                                        // Interpolate kBatch samples at once, then classify and
                                        // composite them in order (early exit after each).
                                        while (s < end && !done) {
                                            constexpr int kB = FastMeanKernel::kBatch;
                                            alignas(64) float val[kB], fx[kB], fy[kB], fz[kB];
                                            alignas(64) int cell[kB];
                                            kernel.cellsAt(a, b, static_cast<int>(s), cell, fx, fy,
                                                           fz);
                                            const int m = static_cast<int>(
                                                std::min<std::int64_t>(kB, end - s));
                                            if (kernel.cellEmpty) {
                                                // All cells empty (common inside non-empty
                                                // bricks): no corner loads at all.
                                                bool any = false;
                                                for (int i = 0; i < m; ++i)
                                                    any |= kernel.cellEmpty[cell[i]] == 0;
                                                if (!any) {
                                                    nSkipped += static_cast<std::uint64_t>(m);
                                                    s += m;
                                                    continue;
                                                }
                                            }
                                            kernel.blend(cell, fx, fy, fz, val);
                                            for (int i = 0; i < m; ++i) {
                                                if (kernel.cellEmpty && kernel.cellEmpty[cell[i]]) {
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
                                            v += static_cast<std::size_t>(std::min(
                                                     static_cast<int>(x), bricks.cells[ax] - 1)) *
                                                 cellStride[ax];
                                        }
                                        if (bricks.cellEmpty[v]) {
                                            ++nSkipped;
                                            continue;
                                        }
                                    }
                                    Rgba c;
                                    if constexpr (std::is_same_v<Kernel, FastMeanKernel>) {
                                        // The mean kernel tests the cell itself (valueAt).
                                        const float v = kernel.valueAt(
                                            a[0] + sf * b[0], a[1] + sf * b[1], a[2] + sf * b[2]);
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
                        }
                        const float rest = 1.f - accA;
                        out[0] = accR + rest * p.background[0];
                        out[1] = accG + rest * p.background[1];
                        out[2] = accB + rest * p.background[2];
                        out[3] = accA;
                    }
            }
            counters.samples += nSamples;
            counters.skipped += nSkipped;
        });
}

}  // namespace udvr::detail
