// The 16-sample batched ray loop (AVX-512): its vector math, TF lookup and compositing against
// scalar references, and whole frames against the per-sample loop. Where the compiler does not
// target AVX-512 only the frame test runs (both frames then take the per-sample loop).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "udvr/classify/fast_tf.h"
#include "udvr/classify/sample_kernels.h"
#include "udvr/classify/tf_table.h"
#include "udvr/data/synthetic.h"
#include "udvr/render/ray_march.h"
#include "udvr/render/render.h"
#include "udvr/stats/model_volume.h"
#include "udvr/util/simd.h"

namespace udvr {
namespace {

#if UDVR_HAVE_AVX512
// The tangle TF with its opacity replaced by ramps and a step at 0.1 (two points at one x).
TransferFunction1D steppedTangleTf() {
    TransferFunction1D tf = tangleTransferFunction();
    tf.opacityX = {-3.0, -1.0, 0.1, 0.1, 2.0, 5.0};
    tf.opacity = {0.2, 0.7, 0.1, 0.9, 0.4, 0.0};
    return tf;
}

std::vector<float> lanes(__m512 v) {
    std::vector<float> out(16);
    _mm512_storeu_ps(out.data(), v);
    return out;
}

TEST(Simd, PrefixProductAndSums) {
    float v[16], want = 1.f;
    for (int i = 0; i < 16; ++i) v[i] = 0.5f + 0.03f * static_cast<float>(i);
    const auto p = lanes(simd::prefixProduct(_mm512_loadu_ps(v)));
    for (int i = 0; i < 16; ++i) {
        want *= v[i];
        EXPECT_NEAR(p[i], want, 1e-6 * want) << i;
    }
    float sums[4];
    simd::sum4(_mm512_set1_ps(1.f), _mm512_loadu_ps(v), _mm512_set1_ps(-2.f), _mm512_setzero_ps(),
               sums);
    double sv = 0;
    for (float x : v) sv += x;
    EXPECT_FLOAT_EQ(sums[0], 16.f);
    EXPECT_NEAR(sums[1], sv, 1e-5);
    EXPECT_FLOAT_EQ(sums[2], -32.f);
    EXPECT_FLOAT_EQ(sums[3], 0.f);
}

TEST(Simd, Transpose16) {
    __m512 r[16];
    for (int i = 0; i < 16; ++i) {
        alignas(64) float row[16];
        for (int j = 0; j < 16; ++j) row[j] = static_cast<float>(100 * i + j);
        r[i] = _mm512_load_ps(row);
    }
    simd::transpose16(r);
    for (int i = 0; i < 16; ++i) {
        const auto row = lanes(r[i]);
        for (int j = 0; j < 16; ++j) EXPECT_EQ(row[j], static_cast<float>(100 * j + i)) << i << j;
    }
}

// 16 random index-space points of `grid` (every fifth on a face) with their cells as the ray
// loop computes them, and a batched kernel's load16 of them.
struct RandomCells16 {
    alignas(64) int base[16];
    alignas(64) float f[3][16], x[3][16];
    RandomCells16(std::mt19937& rng, const Grid3& grid) {
        std::uniform_real_distribution<float> u(0.f, 1.f);
        for (int l = 0; l < 16; ++l) {
            int i[3];
            for (int a = 0; a < 3; ++a) {
                const float m = static_cast<float>(grid.dims[a] - 1);
                x[a][l] = l % 5 == 0 ? m * static_cast<float>(l % 2) : m * u(rng);
                i[a] = std::min(static_cast<int>(x[a][l]), grid.dims[a] - 2);
                f[a][l] = x[a][l] - static_cast<float>(i[a]);
            }
            base[l] = i[0] + grid.dims[0] * (i[1] + grid.dims[1] * i[2]);
        }
    }
    template <class Kernel>
    auto load(const Kernel& k, __mmask16 live) const {
        return k.load16(_mm512_load_si512(base), _mm512_load_ps(f[0]), _mm512_load_ps(f[1]),
                        _mm512_load_ps(f[2]), live);
    }
};

// What the batched-kernel tests share: a seeded generator, the TF's exact tables and a 5×4×3
// grid (small, so random points hit faces and every cell).
struct KernelCase {
    KernelCase(unsigned seed, const TransferFunction1D& tf)
        : rng(seed), table(tf), pieces(table.table()) {
        grid.dims = {5, 4, 3};
    }
    float uniform() { return u(rng); }
    std::mt19937 rng;
    std::uniform_real_distribution<float> u{0.f, 1.f};
    TfTableStorage table;
    detail::TfPieces16 pieces;
    Grid3 grid;
};

// The largest |difference| between a batched kernel's load16 and its double per-sample kernel
// (`exact.classifyAt`) over 40 batches of random points and random live masks; lanes outside
// the mask must come back 0.
template <class Batched, class Exact>
double worstLoad16Error(const Batched& batched, const Exact& exact, std::mt19937& rng,
                        const Grid3& grid) {
    double worst = 0.0;
    for (int trial = 0; trial < 40; ++trial) {
        const RandomCells16 cells(rng, grid);
        const __mmask16 live = static_cast<__mmask16>(rng() & 0xFFFFu);
        const auto got = cells.load(batched, live);
        const std::vector<float> ch[4] = {lanes(got.r), lanes(got.g), lanes(got.b), lanes(got.a)};
        for (int l = 0; l < 16; ++l) {
            const Rgba want = exact.classifyAt(cells.x[0][l], cells.x[1][l], cells.x[2][l]);
            const float w[4] = {want.r, want.g, want.b, want.a};
            for (int c = 0; c < 4; ++c) {
                if (!(live >> l & 1)) {
                    EXPECT_EQ(ch[c][l], 0.f);
                    continue;
                }
                worst = std::max(worst, std::abs(static_cast<double>(ch[c][l]) - w[c]));
            }
        }
    }
    return worst;
}

// The batched float quantile-mean against the double per-sample kernel (SPEC §4 Eq. 5) on random
// models: every q the batch serves, both weightings, quantiles with ties (zero widths) and
// voxels whose quantiles are all equal, random points including the grid's faces.
TEST(FastQuantileMeanKernel, MatchesTheDoubleKernel) {
    for (float offset : {0.f, 1000.f}) {  // data far from 0: narrow widths of large values
        TransferFunction1D tf = tangleTransferFunction();
        for (double& x : tf.colorX) x += offset;
        for (double& x : tf.opacityX) x += offset;
        KernelCase c(11, tf);
        const FastTransferFunction fast(tf);
        const int n = static_cast<int>(c.grid.pointCount());
        for (int q : {1, 2, 3, 4, 7, 8, 9, 15}) {
            std::vector<float> quantiles(static_cast<std::size_t>(n) * (q + 1));
            for (int v = 0; v < n; ++v) {
                float b = offset - 7.f + 12.f * c.uniform();
                const bool allEqual = v % 7 == 3;
                for (int j = 0; j <= q; ++j) {
                    quantiles[static_cast<std::size_t>(v) * (q + 1) + j] = b;
                    if (!allEqual && c.uniform() > 0.2f)  // ties: 20 %, narrow widths: 20 %
                        b += c.uniform() < 0.25f ? 0.002f + 0.001f * c.uniform()
                                                 : 3.f * c.uniform() * c.uniform();
                }
            }
            for (bool density : {true, false}) {
                const QuantileMeanKernel exact{{5, 4, 3}, quantiles.data(), q,
                                               density,   1e-12 * 20.0,     c.table.table()};
                const detail::FastQuantileMeanKernel batched(c.grid, exact, &fast);
                ASSERT_TRUE(batched.batch16());
                // Float boundaries (~7 roundings of |b| ≤ 20, or of |b| ≈ 1000: ~1e−5 resp.
                // ~6e−5 times the TF's steepest opacity slope, 0.9 per unit) against double; the
                // widths behind the density weights are interpolated, not differenced.
                EXPECT_LT(worstLoad16Error(batched, exact, c.rng, c.grid), offset > 0 ? 3e-4 : 2e-5)
                    << q << " " << density << " " << offset;
            }
        }
    }
}

// The batched float quantile-range against the double per-sample kernel (SPEC §4 Eq. 4):
// populations of 2 … 16 boundaries (iqr-like, quartile views, whole q), ties (zero-width
// intervals: TF at the point), intervals inside one TF piece and spanning several, random
// points including the grid's faces.
TEST(FastQuantileRangeKernel, MatchesTheDoubleKernel) {
    KernelCase c(13, steppedTangleTf());
    ASSERT_TRUE(c.pieces.fits);
    const int n = static_cast<int>(c.grid.pointCount());
    for (int q : {1, 2, 4, 8, 15}) {
        std::vector<float> quantiles(static_cast<std::size_t>(n) * (q + 1));
        for (int v = 0; v < n; ++v) {
            float b = -8.f + 14.f * c.uniform();
            for (int j = 0; j <= q; ++j) {
                quantiles[static_cast<std::size_t>(v) * (q + 1) + j] = b;
                if (c.uniform() > 0.2f)
                    b += (c.uniform() < 0.5f ? 0.05f : 3.f) * c.uniform();  // ties: 20 %
            }
        }
        std::vector<std::pair<int, int>> pops{{0, q}};
        if (q % 4 == 0) pops.insert(pops.end(), {{0, q / 4}, {q / 4, 3 * q / 4}, {3 * q / 4, q}});
        for (const auto& [j0, j1] : pops) {
            const QuantileRangeKernel exact{{5, 4, 3}, quantiles.data(), q + 1, j0,
                                            j1,        c.table.table()};
            const detail::FastQuantileRangeKernel batched(c.grid, exact, &c.pieces);
            ASSERT_TRUE(batched.batch16());

            const double worst = worstLoad16Error(batched, exact, c.rng, c.grid);
            // Float boundaries (|b| ≤ 30) against double, as for quantile-mean.
            EXPECT_LT(worst, 2e-5) << q << " " << j0 << " " << j1;
        }
    }
}

// The batched float Gaussian against the double per-sample kernel (expectedTfGaussian):
// σ from 0 (point masses) and tiny to wider than the TF, means inside and outside the TF's
// breakpoints, random points including the grid's faces.
// A TF with a narrow feature: an opacity tent 0.02 wide with a colour ramp across it (where a
// float Gaussian expectation would lose (σ/w)² × float rounding).
TransferFunction1D narrowTentTf() {
    TransferFunction1D tf;
    tf.opacityX = {-5.0, 0.0, 0.01, 0.02, 5.0};
    tf.opacity = {0.0, 0.0, 1.0, 0.0, 0.0};
    tf.colorX = {-5.0, 0.0, 0.02, 5.0};
    tf.color = {{0.2, 0.2, 0.2}, {1.0, 0.0, 0.0}, {0.0, 0.0, 1.0}, {0.2, 0.2, 0.2}};
    return tf;
}

TEST(FastGaussianKernel, MatchesTheDoubleKernel) {
    for (bool narrow : {false, true}) {
        KernelCase c(17, narrow ? narrowTentTf() : steppedTangleTf());
        const std::size_t n = c.grid.pointCount();
        for (float scale : {0.f, 1e-5f, 0.05f, 0.4f, 1.f, 4.f, 40.f, 400.f}) {
            std::vector<float> mean(n), stddev(n);
            for (std::size_t v = 0; v < n; ++v) {
                mean[v] = narrow ? scale * (c.uniform() - 0.5f) : -10.f + 20.f * c.uniform();
                stddev[v] = c.uniform() < 0.2f ? 0.f : scale * c.uniform();
            }
            const GaussianKernel exact{{5, 4, 3}, mean.data(), stddev.data(), c.table.table()};
            const detail::FastGaussianKernel batched(c.grid, exact, &c.pieces);
            ASSERT_TRUE(batched.batch16());

            const double worst = worstLoad16Error(batched, exact, c.rng, c.grid);
            // Float μ and σ (|μ| ≤ 10) and float Φ (≈1e−7) against double; σ wider than 8× the
            // narrowest piece takes the double kernel (the float one was off by 3e−4 at σ = 40w,
            // 0.15 at σ = 1000w).
            EXPECT_LT(worst, 2e-5) << scale << " " << narrow;
        }
    }
}

// The batched float GMM (ordered) against the double per-sample kernel: K = 1, 2, 4, 16, weights
// with zeros (and voxels whose weights are all 0), point-mass components (σ = 0), components too
// wide for the float expectation (their samples take the double kernel).
TEST(FastGmmOrderedKernel, MatchesTheDoubleKernel) {
    KernelCase c(19, tangleTransferFunction());
    const std::size_t n = c.grid.pointCount();
    for (int k : {1, 2, 4, 16}) {
        std::vector<float> gmm(n * 3 * k);
        for (std::size_t v = 0; v < n; ++v) {
            float* g = gmm.data() + v * 3 * k;
            float m = -8.f + 4.f * c.uniform();
            const bool allZero = v % 9 == 4;
            for (int i = 0; i < k; ++i) {
                g[i] = allZero || c.uniform() < 0.2f ? 0.f : c.uniform();
                g[k + i] = m;
                m += 6.f * c.uniform();  // ranks sorted by mean
                // Point masses (σ = 0), and a few σ beyond the float limit (8 × 0.6).
                const float r = c.uniform();
                g[2 * k + i] = r < 0.2f ? 0.f : (r > 0.95f ? 20.f : 2.f) * c.uniform();
            }
        }
        const GmmOrderedKernel exact{{5, 4, 3}, gmm.data(), k, c.table.table()};
        const detail::FastGmmOrderedKernel batched(c.grid, exact, &c.pieces);
        ASSERT_TRUE(batched.batch16());

        const double worst = worstLoad16Error(batched, exact, c.rng, c.grid);
        EXPECT_LT(worst, 2e-5) << k;
    }
}

TEST(OpacityCorrection, Apply16MatchesThePower) {
    // Exponents Δ/u: 1 and ½ (closed forms) and the general path; α from 0 to 1, tiny α and α
    // within a few ulps of 1.
    std::vector<float> as;
    for (int i = 0; i <= 4000; ++i) as.push_back(static_cast<float>(i) / 4000.f);
    for (int i = 1; i < 60; ++i) as.push_back(static_cast<float>(i) * 1e-7f);
    for (int i = 1; i < 60; ++i) as.push_back(1.f - static_cast<float>(i) * 0x1p-24f);
    while (as.size() % 16) as.push_back(0.5f);
    for (float e : {1.f, 0.5f, 0.001f, 0.1234568f, 0.25f, 0.7f, 1.5f, 4.f, 30.f}) {
        const detail::OpacityCorrection correct(e);
        for (std::size_t i = 0; i < as.size(); i += 16) {
            __m512 alpha, keep;
            correct.apply16(_mm512_loadu_ps(&as[i]), alpha, keep);
            const auto ga = lanes(alpha), gk = lanes(keep);
            for (int l = 0; l < 16; ++l) {
                const double a = as[i + l];
                const double k = std::pow(1.0 - a, static_cast<double>(e));
                // α' relative to itself (it scales the colour), 1 − α' absolutely.
                EXPECT_NEAR(ga[l], 1.0 - k, 1e-6 * (1.0 - k) + 1e-12) << e << " " << a;
                EXPECT_NEAR(gk[l], k, 2e-7) << e << " " << a;
            }
        }
    }
}

TEST(FastTransferFunction, Classify16MatchesClassify) {
    const TransferFunction1D tf = steppedTangleTf();
    const FastTransferFunction fast(tf);
    ASSERT_NE(fast.regionArrays(), nullptr);
    std::vector<float> xs;
    for (int i = -2000; i <= 4000; ++i) xs.push_back(static_cast<float>(i) * 0.0123f);
    for (double x : tf.opacityX) xs.push_back(static_cast<float>(x));
    for (double x : tf.colorX) xs.push_back(static_cast<float>(x));
    xs.push_back(-1e30f);
    xs.push_back(1e30f);
    while (xs.size() % 16) xs.push_back(0.f);
    for (std::size_t i = 0; i < xs.size(); i += 16) {
        __m512 r, g, b, a;
        FastTransferFunction::classify16(*fast.regionArrays(), _mm512_loadu_ps(&xs[i]), r, g, b, a);
        const auto vr = lanes(r), vg = lanes(g), vb = lanes(b), va = lanes(a);
        for (int l = 0; l < 16; ++l) {
            const Rgba want = fast.classify(xs[i + l]);  // premultiplied
            EXPECT_NEAR(va[l], want.a, 1e-6) << xs[i + l];
            EXPECT_NEAR(va[l] * vr[l], want.r, 2e-6) << xs[i + l];
            EXPECT_NEAR(va[l] * vg[l], want.g, 2e-6) << xs[i + l];
            EXPECT_NEAR(va[l] * vb[l], want.b, 2e-6) << xs[i + l];
        }
    }
    // NaN contributes nothing either way.
    __m512 r, g, b, a;
    FastTransferFunction::classify16(*fast.regionArrays(), _mm512_set1_ps(std::nanf("")), r, g, b,
                                     a);
    EXPECT_FALSE(lanes(a)[0] > 0.f);
    EXPECT_FALSE(fast.classify(std::nanf("")).a > 0.f);
}

// The SIMD region tables hold 32 regions: 31 breakpoints take the batched paths (and classify
// exactly), 32 fall back to the per-sample ones.
TEST(FastTransferFunction, RegionTablesAtTheirLimit) {
    for (int breaks : {15, 16, 17, 30, 31, 32}) {
        TransferFunction1D tf;
        for (int i = 0; i < breaks; ++i) {
            const double x = i * 0.5;
            tf.opacityX.push_back(x);
            tf.opacity.push_back(i % 3 == 0 ? 0.0 : 0.1 * (i % 7));
        }
        tf.colorX = {0.0, breaks * 0.5 - 0.5};
        tf.color = {{1.0, 0.0, 0.0}, {0.0, 0.0, 1.0}};
        const FastTransferFunction fast(tf);
        const TfTableStorage table(tf);
        const detail::TfPieces16 pieces(table.table());
        EXPECT_EQ(fast.regionArrays() != nullptr, breaks <= 31) << breaks;
        EXPECT_EQ(pieces.fits, breaks <= 31) << breaks;
        if (!fast.regionArrays()) continue;
        for (int i = -4; i < 4 * breaks + 4; i += 16) {
            alignas(64) float x[16];
            for (int l = 0; l < 16; ++l) x[l] = static_cast<float>(i + l) * 0.125f - 0.3f;
            __m512 r, g, b, a;
            FastTransferFunction::classify16(*fast.regionArrays(), _mm512_load_ps(x), r, g, b, a);
            const auto va = lanes(a), vr = lanes(r);
            for (int l = 0; l < 16; ++l) {
                const Rgba want = fast.classify(x[l]);
                EXPECT_NEAR(va[l], want.a, 1e-6) << breaks << " " << x[l];
                EXPECT_NEAR(va[l] * vr[l], want.r, 1e-6) << breaks << " " << x[l];
            }
        }
    }
}

TEST(BatchCompositor, MatchesSerialFrontToBack) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    for (float e : {1.f, 0.5f, 0.37f, 2.5f}) {
        const detail::OpacityCorrection correct(e);
        for (int trial = 0; trial < 200; ++trial) {
            const float earlyExit = trial % 3 == 0 ? 1.f : 0.95f;
            detail::BatchCompositor comp;
            double accR = 0, accG = 0, accB = 0, accA = 0;  // the SPEC §5 recurrence, double
            bool doneRef = false, doneGot = false;
            for (int batch = 0; batch < 4 && !doneGot; ++batch) {
                alignas(64) float pr[16], pg[16], pb[16], pa[16];
                __mmask16 live = 0;
                for (int l = 0; l < 16; ++l) {
                    pa[l] = u(rng) < 0.2f ? 0.f : 0.3f * u(rng) * u(rng);
                    pr[l] = pa[l] * u(rng);
                    pg[l] = pa[l] * u(rng);
                    pb[l] = pa[l] * u(rng);
                    if (u(rng) < 0.8f) live |= static_cast<__mmask16>(1u << l);
                }
                doneGot = comp.add(_mm512_load_ps(pr), _mm512_load_ps(pg), _mm512_load_ps(pb),
                                   _mm512_load_ps(pa), live, correct, 1.f - earlyExit);
                for (int l = 0; l < 16 && !doneRef; ++l) {
                    if (!(live >> l & 1) || !(pa[l] > 0.f)) continue;
                    const double a = pa[l];
                    const double alpha = 1.0 - std::pow(1.0 - a, static_cast<double>(e));
                    const double w = (1.0 - accA) * alpha / a;
                    accR += w * pr[l];
                    accG += w * pg[l];
                    accB += w * pb[l];
                    accA += (1.0 - accA) * alpha;
                    doneRef = accA > earlyExit;
                }
                ASSERT_EQ(doneGot, doneRef) << trial << " " << batch;
            }
            float r, g, b, a;
            comp.result(r, g, b, a);
            EXPECT_NEAR(r, accR, 2e-6);
            EXPECT_NEAR(g, accG, 2e-6);
            EXPECT_NEAR(b, accB, 2e-6);
            EXPECT_NEAR(a, accA, 2e-6);
        }
    }
}
#endif

// The brick walk of the batched loop never jumps a sample whose brick is not empty, and walks
// past every empty brick the per-brick test would: random rays (inside, outside and through
// the grid, axis-parallel ones too) over random brick tables.
TEST(SkipTable, BrickWalkSkipsOnlyEmptyBricks) {
    std::mt19937 rng(23);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    detail::SkipTable t;
    for (int a = 0; a < 3; ++a) {
        t.dims[a] = 70 + 9 * a;
        t.cells[a] = t.dims[a] - 1;
        t.bricks[a] = (t.cells[a] + detail::kBrickCells - 1) / detail::kBrickCells;
    }
    const std::size_t nBricks = static_cast<std::size_t>(t.bricks[0]) * t.bricks[1] * t.bricks[2];
    const auto brickOf = [&](const detail::RaySamples& r, std::int64_t k) {
        int br[3];
        for (int a = 0; a < 3; ++a) {
            const float v = r.a[a] + static_cast<float>(k) * r.b[a];
            const float vc = std::clamp(v, 0.f, static_cast<float>(t.cells[a]));
            br[a] = std::min(static_cast<int>(vc), t.cells[a] - 1) / detail::kBrickCells;
        }
        return t.index(br[0], br[1], br[2]);
    };
    int jumps = 0;
    for (int trial = 0; trial < 300; ++trial) {
        t.empty.assign(nBricks, 0);
        const float fill = u(rng);
        for (auto& e : t.empty) e = u(rng) < fill ? 1 : 0;
        detail::RaySamples r;
        for (int a = 0; a < 3; ++a) {
            r.a[a] = -20.f + (static_cast<float>(t.dims[a]) + 40.f) * u(rng);
            r.b[a] = trial % 7 == a ? 0.f : 0.8f * (u(rng) - 0.5f);
            r.invB[a] = r.b[a] != 0.f ? 1.f / r.b[a] : 0.f;
        }
        r.n = 200 + static_cast<std::int64_t>(300 * u(rng));
        std::int64_t s = 0;
        while (s < r.n) {
            const std::int64_t s0 = s;
            std::uint64_t skipped = 0;
            if (detail::skipEmptyBricks(t, r, s, skipped)) {
                ++jumps;
                ASSERT_GT(s, s0);
                ASSERT_EQ(skipped, static_cast<std::uint64_t>(s - s0));
                for (std::int64_t k = s0; k < std::min(s, r.n); ++k)
                    ASSERT_TRUE(t.empty[brickOf(r, k)]) << trial << " sample " << k;
            } else {
                ASSERT_FALSE(t.empty[brickOf(r, s)]) << trial << " sample " << s;
                ++s;
            }
        }
    }
    EXPECT_GT(jumps, 300);  // the walks were exercised (606 with this seed)
}

// The same TF written with many redundant (collinear) control points is the same function but
// has too many regions for the batched loop, so the frame takes the per-sample loop: the two
// frames agree to float rounding (with or without AVX-512), for the mean field, quantile-mean
// with both weightings and the quantile-range family.
// The tangle with quantiles around its value (q = 8; a tie in every voxel), for quantile-mean;
// `flat`: only its plane x = 20 (a 1-point x axis: no x-neighbour to load).
ModelVolume tangleWithQuantiles(bool flat) {
    ScalarField f = makeTangle(40, 36, 44);
    if (flat) {
        ScalarField plane;
        plane.grid = f.grid;
        plane.grid.dims = {1, 36, 44};
        plane.grid.origin[0] += 20 * f.grid.spacing[0];
        for (int z = 0; z < 44; ++z)
            for (int y = 0; y < 36; ++y) plane.values.push_back(f.values[f.grid.index(20, y, z)]);
        f = plane;
    }
    ModelVolume m = modelFromField(f);
    if (flat) {  // a slab one unit thick around the plane (samples clamp into it)
        m.bounds[0] -= 0.5;
        m.bounds[1] += 0.5;
    }
    constexpr std::array<float, 9> offsets{-2.5f, -1.f, -0.5f, -0.5f, 0.1f, 0.4f, 0.9f, 7.f, 10.f};
    m.quantileCount = 8;
    m.quantiles.resize(m.voxelCount() * 9);
    m.iqr.resize(m.voxelCount() * 2);
    m.gmmComponents = 2;
    m.gmm.resize(m.voxelCount() * 6);
    for (std::size_t v = 0; v < m.voxelCount(); ++v) {
        m.stddev[v] = 0.3f + 0.2f * std::sin(static_cast<float>(v));
        const float g[6] = {0.8f, 0.2f, m.mean[v], m.mean[v] + 8.f, 0.4f, 1.5f};
        std::copy(g, g + 6, m.gmm.begin() + static_cast<std::ptrdiff_t>(6 * v));
        for (int j = 0; j < 9; ++j) m.quantiles[v * 9 + j] = m.mean[v] + offsets[j];
        m.iqr[2 * v] = m.mean[v] + offsets[2];
        m.iqr[2 * v + 1] = m.mean[v] + offsets[6];
    }
    return m;
}

TEST(Render, BatchedAndPerSampleLoopsGiveTheSameFrame) {
    const TransferFunction1D tf = tangleTransferFunction();
    TransferFunction1D dense = tf;
    // Insert 40 points on the first opacity segment's line (and on the colour line).
    const double x0 = tf.opacityX[0], x1 = tf.opacityX[1];
    std::vector<double> ox{x0}, o{tf.opacity[0]};
    for (int i = 1; i <= 40; ++i) {
        const double t = i / 41.0;
        ox.push_back(x0 + t * (x1 - x0));
        o.push_back(tf.opacity[0] + t * (tf.opacity[1] - tf.opacity[0]));
    }
    for (std::size_t i = 1; i < tf.opacityX.size(); ++i) {
        ox.push_back(tf.opacityX[i]);
        o.push_back(tf.opacity[i]);
    }
    dense.opacityX = ox;
    dense.opacity = o;
    ASSERT_NE(FastTransferFunction(tf).regionArrays(), nullptr);
    ASSERT_EQ(FastTransferFunction(dense).regionArrays(), nullptr);
    for (bool flat : {false, true})
        for (double unit : {0.0, 0.3, 0.05}) {  // exponent ½ (default), < 1 and > 1
            const ModelVolume m = tangleWithQuantiles(flat);
            RenderSettings s;
            s.width = 72;
            s.height = 64;
            s.camera = defaultCamera(m.bounds, 30.0, 20.0);
            s.unitDistance = unit;
            if (unit == 0.05) s.jitterSeed = 5;
            for (bool skip : {true, false}) {
                s.skipEmpty = skip;
                for (ModelKind kind :
                     {ModelKind::Mean, ModelKind::QuantileMean, ModelKind::QuantileMeanMass,
                      ModelKind::QuantileRange, ModelKind::QuartileUpper, ModelKind::Iqr,
                      ModelKind::Gaussian, ModelKind::GmmOrdered}) {
                    RenderStats sa;
                    const ImageRgba a = renderVolume(m, kind, tf, s, &sa);
                    const ImageRgba b = renderVolume(m, kind, dense, s);
                    double worst = 0.0;
                    for (std::size_t i = 0; i < a.rgba.size(); ++i)
                        worst =
                            std::max(worst, std::abs(static_cast<double>(a.rgba[i]) - b.rgba[i]));
                    // Mean: float both ways; the quantile models: float against the double kernels.
                    EXPECT_LE(worst, kind == ModelKind::Mean ? 2e-5 : 1e-4)
                        << modelName(kind) << " " << unit << " " << skip << " " << flat;
                    EXPECT_GT(sa.samples, 0u);
                }
            }
        }
}

}  // namespace
}  // namespace udvr
