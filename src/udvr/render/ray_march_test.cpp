// The ray loop's parts against scalar references: the lanes (util/lanes.h) against plain loops,
// the opacity correction against the power in double, the compositor against the serial
// front-to-back recurrence of SPEC §5, the brick walk against the per-brick test; and whole
// frames of every model against an in-test serial ray marcher over the double kernels.
#include "udvr/render/ray_march.h"

#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <limits>
#include <random>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "udvr/classify/classify_test_util.h"
#include "udvr/classify/model_families.h"
#include "udvr/classify/tf_presets.h"
#include "udvr/data/synthetic.h"
#include "udvr/render/render.h"
#include "udvr/stats/model_view.h"
#include "udvr/stats/model_volume.h"
#include "udvr/util/check.h"
#include "udvr/util/parallel.h"

namespace udvr {
namespace {

using lanes::Mask;
using lanes::Vf;
using lanes::Vi;

Vf randomVf(std::mt19937& rng, float lo, float hi) {
    std::uniform_real_distribution<float> u(lo, hi);
    Vf v;
    for (int l = 0; l < lanes::kWidth; ++l) v[l] = u(rng);
    return v;
}
// Every lane's bit.
constexpr std::uint32_t kAll = (1u << lanes::kWidth) - 1u;
Mask randomMask(std::mt19937& rng) { return lanes::fromBits(rng() & kAll); }

// ---- lanes --------------------------------------------------------------------------------

TEST(Lanes, MaskBitsRoundTrip) {
    std::mt19937 rng(1);
    for (int trial = 0; trial < 100; ++trial) {
        const std::uint32_t b = trial == 0 ? 0u : (trial == 1 ? kAll : rng() & kAll);
        const Mask m = lanes::fromBits(b);
        for (int l = 0; l < lanes::kWidth; ++l) EXPECT_EQ(m[l], (b >> l & 1u) ? -1 : 0);
        EXPECT_EQ(lanes::bits(m), b);
        EXPECT_EQ(lanes::anyOf(m), b != 0);
        EXPECT_EQ(lanes::noneOf(m), b == 0);
        EXPECT_EQ(lanes::allOf(m), b == kAll);
    }
    for (int n = 0; n <= lanes::kWidth; ++n)
        EXPECT_EQ(lanes::bits(lanes::firstLanes(n)), (1u << n) - 1u) << n;
}

// expandFirst: the k-th lane of the mask takes src[k], the others keep the fallback; every
// target packs (the segment pool hands its items out so).
TEST(Lanes, ExpandFirstHandsItemsToTheMaskedLanesInOrder) {
    std::mt19937 rng(2);
    float src[lanes::kWidth];
    for (int k = 0; k < lanes::kWidth; ++k) src[k] = 10.0f + static_cast<float>(k);
    for (int trial = 0; trial < 100; ++trial) {
        const Mask m = trial == 0 ? lanes::fromBits(0u) : randomMask(rng);
        const Vf f = lanes::expandFirst(src, m, Vf{} - 1.0f);
        int k = 0;
        for (int l = 0; l < lanes::kWidth; ++l) {
            EXPECT_EQ(f[l], m[l] ? src[k] : -1.0f);
            k += m[l] ? 1 : 0;
        }
    }
}

TEST(Lanes, PrefixProductAndSum) {
    std::mt19937 rng(2);
    for (int trial = 0; trial < 200; ++trial) {
        const Vf v = randomVf(rng, trial % 2 ? 0.f : -1.5f, 1.5f);
        const Vf p = lanes::prefixProduct(v);
        double want = 1.0, sum = 0.0, sumAbs = 0.0;
        for (int l = 0; l < lanes::kWidth; ++l) {
            want *= v[l];
            // A product of ≤ 16 floats: ≤ 15 roundings of 2^−24 relative.
            EXPECT_NEAR(p[l], want, 1e-6 * std::abs(want)) << l;
            sum += v[l];
            sumAbs += std::abs(v[l]);
        }
        // A sum of ≤ 16 floats: ≤ 15 roundings, each ≤ 2^−24 of a partial sum (≤ Σ|v|).
        EXPECT_NEAR(lanes::sum(v), sum, 1e-6 * sumAbs);
    }
}

// The double lanes' sqrt, floor, ceil and conversions give each lane what the scalar functions
// give it (the 2D gaussian's row setups rely on it: its images equal the scalar setups' bit for
// bit).
TEST(Lanes, DoubleLanesRoundAndConvertAsScalars) {
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-40.0, 40.0);
    for (int trial = 0; trial < 200; ++trial) {
        lanes::V8d x;
        for (int l = 0; l < 8; ++l) x[l] = trial % 4 ? u(rng) : std::round(u(rng)) + (l % 2) * 0.5;
        const lanes::V8d s = lanes::sqrt(x * x), f = lanes::floor(x), c = lanes::ceil(x);
        const lanes::V8i t = lanes::truncToInt(c);
        const lanes::V8f h = lanes::toFloat(x);
        for (int l = 0; l < 8; ++l) {
            EXPECT_EQ(s[l], std::sqrt(x[l] * x[l])) << l;
            EXPECT_EQ(f[l], std::floor(x[l])) << l;
            EXPECT_EQ(c[l], std::ceil(x[l])) << l;
            EXPECT_EQ(t[l], static_cast<int>(std::ceil(x[l]))) << l;
            EXPECT_EQ(h[l], static_cast<float>(x[l])) << l;
        }
    }
}

TEST(Lanes, Transpose) {
    constexpr int n = lanes::kWidth;
    Vf r[n];
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) r[i][j] = static_cast<float>(100 * i + j);
    lanes::transpose(r);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) EXPECT_EQ(r[i][j], static_cast<float>(100 * j + i)) << i << j;
}

template <int K>
void expectShiftUp(const Vf& v, const Vf& fill) {
    const Vf s = lanes::shiftUp<K>(v, fill);
    for (int l = 0; l < lanes::kWidth; ++l) EXPECT_EQ(s[l], l >= K ? v[l - K] : fill[l]) << K;
}
template <int... K>
void expectAllShiftUps(const Vf& v, const Vf& fill, std::integer_sequence<int, K...>) {
    (expectShiftUp<K + 1>(v, fill), ...);
}

TEST(Lanes, ShiftUpByEveryCount) {
    std::mt19937 rng(3);
    const Vf v = randomVf(rng, -1.f, 1.f), fill = randomVf(rng, 2.f, 3.f);
    expectAllShiftUps(v, fill, std::make_integer_sequence<int, lanes::kWidth - 1>{});
}

// Dead lanes hold indices far outside the table (2^28 floats = 1 GiB past it): a gather that
// read them would fault or return garbage.
TEST(Lanes, GatherAndGatherPairSkipDeadLanes) {
    std::mt19937 rng(4);
    std::vector<float> base(101);
    for (std::size_t i = 0; i < base.size(); ++i) base[i] = static_cast<float>(i) * 0.5f - 7.f;
    for (int trial = 0; trial < 100; ++trial) {
        const Mask live =
            trial == 0 ? Mask{} : (trial == 1 ? lanes::fromBits(kAll) : randomMask(rng));
        Vi idx;
        for (int l = 0; l < lanes::kWidth; ++l)  // gatherRow8 reads idx … idx + 7 ≤ 100
            idx[l] = live[l] ? static_cast<int>(rng() % 94) : (1 << 28) + l;
        const Vf g = lanes::gather(base.data(), idx, live);
        Vf v0, v1, row[8];
        lanes::gatherPair(base.data(), idx, live, v0, v1);
        lanes::gatherRow8(base.data(), idx, live, row);
        for (int l = 0; l < lanes::kWidth; ++l) {
            const bool on = live[l] != 0;
            EXPECT_EQ(g[l], on ? base[idx[l]] : 0.f) << l;
            EXPECT_EQ(v0[l], on ? base[idx[l]] : 0.f) << l;
            EXPECT_EQ(v1[l], on ? base[idx[l] + 1] : 0.f) << l;
            for (int k = 0; k < 8; ++k) EXPECT_EQ(row[k][l], on ? base[idx[l] + k] : 0.f) << l;
        }
    }
}

TEST(Lanes, LookupOfSmallAndAnyTables) {
    std::mt19937 rng(5);
    std::vector<float> table(300);
    for (std::size_t i = 0; i < table.size(); ++i) table[i] = std::sin(static_cast<float>(i));
    for (int trial = 0; trial < 100; ++trial) {
        Vi small, any;
        for (int l = 0; l < lanes::kWidth; ++l) {
            small[l] = trial == 0 ? 31 - l : static_cast<int>(rng() % 32);
            any[l] = static_cast<int>(rng() % 300);
        }
        const Vf a = lanes::lookup<32>(table.data(), small);
        const Vf b = lanes::lookup<0>(table.data(), any);
        const Vf c = lanes::lookup<0>(table.data(), small);
        for (int l = 0; l < lanes::kWidth; ++l) {
            EXPECT_EQ(a[l], table[small[l]]);
            EXPECT_EQ(b[l], table[any[l]]);
            EXPECT_EQ(c[l], table[small[l]]);
        }
    }
}

TEST(Lanes, TestBitsReadsOnlyLiveLanes) {
    std::mt19937 rng(6);
    std::vector<std::uint32_t> table(10);
    for (auto& w : table) w = static_cast<std::uint32_t>(rng());
    for (int trial = 0; trial < 100; ++trial) {
        const Mask live = randomMask(rng);
        Vi v;
        for (int l = 0; l < lanes::kWidth; ++l)
            v[l] = live[l] ? static_cast<int>(rng() % 320) : (1 << 30) + l;
        const Mask got = lanes::testBits(table.data(), v, live);
        for (int l = 0; l < lanes::kWidth; ++l) {
            const bool want = live[l] && ((table[v[l] >> 5] >> (v[l] & 31)) & 1u);
            EXPECT_EQ(got[l] != 0, want) << l;
        }
    }
}

// A readable page followed by one that may not be read (PROT_NONE): a load past end() faults.
class PageBeforeAGuard {
  public:
    PageBeforeAGuard() : page_(static_cast<std::size_t>(sysconf(_SC_PAGESIZE))) {
        mem_ = mmap(nullptr, 2 * page_, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (mem_ == MAP_FAILED) return;
        guarded_ = mprotect(static_cast<char*>(mem_) + page_, page_, PROT_NONE) == 0;
    }
    ~PageBeforeAGuard() {
        if (mem_ != MAP_FAILED) munmap(mem_, 2 * page_);
    }
    PageBeforeAGuard(const PageBeforeAGuard&) = delete;
    PageBeforeAGuard& operator=(const PageBeforeAGuard&) = delete;
    bool ok() const { return mem_ != MAP_FAILED && guarded_; }
    /// One past the readable page's last float.
    float* end() const { return reinterpret_cast<float*>(static_cast<char*>(mem_) + page_); }

  private:
    std::size_t page_;
    void* mem_ = MAP_FAILED;
    bool guarded_ = false;
};

// loadFirst(p, n) reads nothing past p[n − 1]: p[n − 1] is the last float before a page that
// may not be read.
TEST(Lanes, LoadFirstStopsAtTheLastElement) {
    const PageBeforeAGuard mem;
    ASSERT_TRUE(mem.ok());
    float* end = mem.end();
    for (int i = 1; i <= lanes::kWidth; ++i) end[-i] = static_cast<float>(100 + i);
    for (int n = 0; n <= lanes::kWidth; ++n) {
        const float* p = end - n;
        const Vf v = lanes::loadFirst(p, n);
        for (int l = 0; l < lanes::kWidth; ++l)
            EXPECT_EQ(v[l], l < n ? p[l] : 0.f) << n << " " << l;
    }
}

// loadHalves(lo, hi) puts lo's kWidth/2 floats below hi's and reads nothing past either: both
// rows end at a page that may not be read.
TEST(Lanes, LoadHalvesJoinsTwoRowsReadingNothingPastThem) {
    const PageBeforeAGuard mem;
    ASSERT_TRUE(mem.ok());
    constexpr int kHalf = lanes::kWidth / 2;
    float* end = mem.end();
    float* hi = end - kHalf;
    float* lo = end - 3 * kHalf;  // a gap of kHalf floats between the rows
    for (int i = 0; i < kHalf; ++i)
        lo[i] = static_cast<float>(10 + i), hi[i] = -1.5f * static_cast<float>(i);
    for (int i = 0; i < kHalf; ++i) lo[kHalf + i] = 999.f;
    const Vf v = lanes::loadHalves(lo, hi);
    for (int l = 0; l < lanes::kWidth; ++l) EXPECT_EQ(v[l], l < kHalf ? lo[l] : hi[l - kHalf]) << l;
}

// less and selectBits on vectors wider than a register (compared a register at a time) against
// the lane-by-lane operators, NaN lanes included.
TEST(Lanes, LessAndSelectBitsOfWideVectorsMatchTheOperators) {
    using V = lanes::Vec<double, 16>;
    using W = lanes::Vec<float, 32>;
    std::mt19937 rng(7);
    std::uniform_int_distribution<int> pick(-2, 2);
    for (int trial = 0; trial < 50; ++trial) {
        V a, b;
        W fa, fb;
        for (int l = 0; l < 16; ++l) {
            a[l] = pick(rng);
            b[l] = l == trial % 16 ? std::numeric_limits<double>::quiet_NaN() : pick(rng);
        }
        for (int l = 0; l < 32; ++l) {
            fa[l] = static_cast<float>(pick(rng));
            fb[l] = static_cast<float>(pick(rng));
        }
        const auto m = lanes::less(a, b);
        const V s = lanes::selectBits(m, a, b);
        const auto fm = lanes::less(fa, fb);
        const W fs = lanes::selectBits(fm, fa, fb);
        for (int l = 0; l < 16; ++l) {
            EXPECT_EQ(m[l], a[l] < b[l] ? -1 : 0) << l;
            if (std::isnan(b[l]))
                EXPECT_TRUE(std::isnan(s[l])) << l;  // NaN compares false: b's lane
            else
                EXPECT_EQ(s[l], a[l] < b[l] ? a[l] : b[l]) << l;
        }
        for (int l = 0; l < 32; ++l) {
            EXPECT_EQ(fm[l], fa[l] < fb[l] ? -1 : 0) << l;
            EXPECT_EQ(fs[l], fa[l] < fb[l] ? fa[l] : fb[l]) << l;
        }
    }
}

TEST(Lanes, MinAndMaxOverLiveLanes) {
    std::mt19937 rng(7);
    for (int trial = 0; trial < 200; ++trial) {
        Mask live = randomMask(rng);
        if (lanes::noneOf(live)) live = lanes::firstLanes(1);
        Vi v;
        for (int l = 0; l < lanes::kWidth; ++l) {
            const std::uint32_t r = static_cast<std::uint32_t>(rng());
            v[l] =
                trial % 10 == 0 ? (r % 2 ? INT_MAX : INT_MIN) : static_cast<int>(r % 2001) - 1000;
        }
        int lo = INT_MAX, hi = INT_MIN;
        for (int l = 0; l < lanes::kWidth; ++l)
            if (live[l]) {
                lo = std::min(lo, v[l]);
                hi = std::max(hi, v[l]);
            }
        EXPECT_EQ(lanes::minOf(v, live), lo);
        EXPECT_EQ(lanes::maxOf(v, live), hi);
    }
}

// ---- opacity correction and compositing -----------------------------------------------------

// α' = 1 − (1 − α)^e against the power in double over α ∈ [0, 1] (a fine grid, tiny α, α within
// a few ulps of 1, and 1) for exponents below, at and above 1 (and the exact forms e = 1, ½):
// the error contract of ray_march.h, ≤ 1e−6 relative in α' and ≤ 1e−6 absolute in 1 − α'.
// Measured worst (AVX-512): 5.0e−7 relative in α' (e = 1.7), 1.7e−7 in 1 − α'.
TEST(OpacityCorrection, ApplyMatchesThePowerWithinTheContract) {
    std::vector<float> as;
    for (int i = 0; i <= 20000; ++i) as.push_back(static_cast<float>(i) / 20000.f);
    for (int i = 1; i < 200; ++i) as.push_back(static_cast<float>(i) * 1e-7f);
    for (int i = 1; i < 50; ++i) as.push_back(std::ldexp(1.f, -10 - 2 * i));  // down to 2^−108
    for (int i = 1; i < 200; ++i) as.push_back(1.f - static_cast<float>(i) * 0x1p-24f);
    for (int i = 0; i < 200; ++i) as.push_back(0.25f + static_cast<float>(i - 100) * 0x1p-24f);
    while (as.size() % lanes::kWidth) as.push_back(1.f);
    for (float e : {0.001f, 0.1f, 0.5f, 1.f, 1.7f, 2.5f, 30.f}) {
        const detail::OpacityCorrection correct(e);
        for (std::size_t i = 0; i < as.size(); i += lanes::kWidth) {
            Vf alpha, keep;
            correct.apply(lanes::load(&as[i]), lanes::allTrue<Vf>(), alpha, keep);
            for (int l = 0; l < lanes::kWidth; ++l) {
                // (1 − α)^e and 1 − (1 − α)^e in double as e^{e·ln(1 − α)} and −expm1(…): the
                // difference 1 − pow(1 − α, e) has an error of ~ulp(1) = 2e−16, more than 1e−6
                // of α' below α' ~ 1e−10.
                const double a = as[i + l];
                const double lnKeep = static_cast<double>(e) * std::log1p(-a);
                const double k = std::exp(lnKeep), exact = -std::expm1(lnKeep);
                // The relative error of α' (it scales the colour), and 1 − α' absolutely.
                const double rel = exact > 0.0 ? std::abs(alpha[l] - exact) / exact
                                               : (alpha[l] == 0.f ? 0.0 : INFINITY);
                EXPECT_LE(rel, 1e-6) << e << " " << a;
                EXPECT_LE(std::abs(keep[l] - k), 1e-6) << e << " " << a;
            }
        }
    }
}

TEST(Compositor, MatchesSerialFrontToBack) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    for (float e : {1.f, 0.5f, 0.37f, 2.5f}) {
        const detail::OpacityCorrection correct(e);
        for (int trial = 0; trial < 200; ++trial) {
            const float earlyExit = trial % 3 == 0 ? 1.f : 0.95f;
            detail::Compositor comp;
            double accR = 0, accG = 0, accB = 0, accA = 0;  // the SPEC §5 recurrence, double
            bool doneRef = false, doneGot = false;
            for (int batch = 0; batch < 64 / lanes::kWidth && !doneGot; ++batch) {
                Vf c[4];
                Mask live{};
                for (int l = 0; l < lanes::kWidth; ++l) {
                    c[3][l] = u(rng) < 0.2f ? 0.f : 0.3f * u(rng) * u(rng);
                    c[0][l] = c[3][l] * u(rng);
                    c[1][l] = c[3][l] * u(rng);
                    c[2][l] = c[3][l] * u(rng);
                    live[l] = u(rng) < 0.8f ? -1 : 0;
                }
                doneGot = comp.add(c, live, correct, 1.f - earlyExit);
                for (int l = 0; l < lanes::kWidth && !doneRef; ++l) {
                    if (!live[l] || !(c[3][l] > 0.f)) continue;
                    const double a = c[3][l];
                    const double alpha = 1.0 - std::pow(1.0 - a, static_cast<double>(e));
                    const double w = (1.0 - accA) * alpha / a;
                    accR += w * c[0][l];
                    accG += w * c[1][l];
                    accB += w * c[2][l];
                    accA += (1.0 - accA) * alpha;
                    doneRef = accA > earlyExit;
                }
                ASSERT_EQ(doneGot, doneRef) << trial << " " << batch;
            }
            float r, g, b, a;
            comp.result(r, g, b, a);
            // ≤ 64 samples of float products and sums against double (measured 2.0e−7).
            EXPECT_NEAR(r, accR, 2e-6);
            EXPECT_NEAR(g, accG, 2e-6);
            EXPECT_NEAR(b, accB, 2e-6);
            EXPECT_NEAR(a, accA, 2e-6);
        }
    }
}

// ---- the brick walk -------------------------------------------------------------------------

// The brick walk never jumps a sample whose brick is not empty: random rays (inside, outside
// and through the grid, axis-parallel ones too) over random brick tables.
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
    EXPECT_GT(jumps, 300);  // the walks were exercised
}

// ---- whole frames ---------------------------------------------------------------------------

// The frame parameters renderVolume uses (SPEC §5), written out here: the model's bounds (its
// grid's box when unset), Δ = ½ × the smallest full-resolution spacing and u = that spacing
// unless given, e = Δ/u.
detail::MarchParams referenceParams(const ModelVolume& m, const RenderSettings& s) {
    detail::MarchParams p;
    p.frame = makeCameraFrame(s.camera, s.width, s.height);
    bool unset = true;
    for (double b : m.bounds) unset = unset && b == 0.0;
    p.bounds = unset ? m.grid.bounds() : m.bounds;
    p.grid = m.grid;
    const double full = m.fullResMinSpacing > 0.0 ? m.fullResMinSpacing : m.grid.minSpacing();
    p.step = s.step > 0.0 ? s.step : 0.5 * full;
    const double unit = s.unitDistance > 0.0 ? s.unitDistance : full;
    p.opacityExponent = static_cast<float>(p.step / unit);
    p.earlyExit = static_cast<float>(s.earlyExit);
    p.background = s.background;
    p.jitter = s.jitterSeed.has_value();
    p.jitterSeed = s.jitterSeed.value_or(0);
    return p;
}

// A serial ray marcher over the double body of `kind` (SPEC §5): the samples of raySamples,
// classifyAt<double> at each, α' = 1 − (1 − E[α])^(Δ/u) in double, colour scaled by α'/E[α],
// front to back with the early exit checked after each sample, the background last. Pixels
// whose accumulated α comes within `margin` of the exit threshold after some sample are marked
// NaN: the float renderer may stop one sample earlier or later there.
ImageRgba referenceFrame(const ModelVolume& m, ModelKind kind, const TransferFunction1D& tf,
                         const RenderSettings& s, double margin) {
    const detail::MarchParams p = referenceParams(m, s);
    ImageRgba img;
    img.width = s.width;
    img.height = s.height;
    img.rgba.assign(static_cast<std::size_t>(s.width) * s.height * 4, 0.f);
    ClassifyOptions options;
    options.uniformMinMax = s.uniformMinMax;
    const double e = p.opacityExponent, exitAt = p.earlyExit;
    withKernel(m, kind, tf, options, [&](const auto& k) {
        for (int py = 0; py < s.height; ++py)
            for (int px = 0; px < s.width; ++px) {
                const detail::RaySamples r = detail::raySamples(p, px, py);
                double acc[4] = {0, 0, 0, 0};
                bool ambiguous = false;
                for (std::int64_t i = 0; i < r.n; ++i) {
                    // The sample position a + i·b, rounded as the renderer's lanes round it.
                    float x[3];
                    for (int ax = 0; ax < 3; ++ax)
                        x[ax] = lanes::fma(lanes::splat<Vf>(static_cast<float>(i)),
                                           lanes::splat<Vf>(r.b[ax]), lanes::splat<Vf>(r.a[ax]))[0];
                    double c[4];
                    classifyAt<double>(k, x[0], x[1], x[2], c);
                    if (!(c[3] > 0.0)) continue;
                    const double a = std::min(c[3], 1.0);
                    const double alpha = 1.0 - std::pow(1.0 - a, e);
                    const double w = (1.0 - acc[3]) * alpha / a;
                    for (int ch = 0; ch < 3; ++ch) acc[ch] += w * c[ch];
                    acc[3] += (1.0 - acc[3]) * alpha;
                    ambiguous = ambiguous || (exitAt < 1.0 && std::abs(acc[3] - exitAt) < margin);
                    if (acc[3] > exitAt) break;
                }
                float* out = img.pixel(px, py);
                for (int ch = 0; ch < 3; ++ch)
                    out[ch] = static_cast<float>(acc[ch] + (1.0 - acc[3]) * p.background[ch]);
                out[3] = static_cast<float>(acc[3]);
                if (ambiguous) out[0] = NAN;
            }
    });
    return img;
}

double maxAbsDiff(const ImageRgba& a, const ImageRgba& b, int* skipped = nullptr) {
    double m = 0.0;
    for (std::size_t i = 0; i < a.rgba.size(); i += 4) {
        if (std::isnan(a.rgba[i]) || std::isnan(b.rgba[i])) {
            if (skipped) ++*skipped;
            continue;
        }
        for (std::size_t ch = 0; ch < 4; ++ch)
            m = std::max(m, std::abs(static_cast<double>(a.rgba[i + ch]) - b.rgba[i + ch]));
    }
    return m;
}

// A tiny random model with the tangle's structure (every array, q = 8, K = 3): each voxel's
// random distribution (testing::randomModel: normal, skewed, bimodal, tied or constant samples)
// narrowed to 0.3× its spread and moved so that its mean is the 13³ tangle's value there, so
// the TF's transparent ranges leave empty cells and bricks. `wide`: the rendered box is larger
// than the grid's (a downsampled model's full-resolution bounds: samples clamp).
ModelVolume tinyModel(std::uint64_t seed, bool wide) {
    const ScalarField f = makeTangle(13, 13, 13);
    CounterRng rng(seed, 0, 0);
    ModelVolume m = testing::randomModel(rng, f.grid.dims, 8, 3);
    m.grid = f.grid;
    const double s = 0.3;
    for (std::size_t v = 0; v < m.voxelCount(); ++v) {
        const double mean = m.mean[v], to = f.values[v];
        const auto move = [&](float& x) { x = static_cast<float>(to + s * (x - mean)); };
        move(m.mean[v]);
        move(m.min[v]);
        move(m.max[v]);
        m.stddev[v] = static_cast<float>(s * m.stddev[v]);
        for (int j = 0; j <= 8; ++j) move(m.quantiles[v * 9 + j]);
        move(m.iqr[2 * v]);
        move(m.iqr[2 * v + 1]);
        for (int i = 0; i < m.memberCount; ++i) move(m.members[v * m.memberCount + i]);
        for (int k = 0; k < 3; ++k) {
            move(m.gmm[v * 9 + 3 + k]);
            m.gmm[v * 9 + 6 + k] = static_cast<float>(s * m.gmm[v * 9 + 6 + k]);
        }
    }
    if (wide) {
        m.bounds = m.grid.bounds();
        for (int a = 0; a < 3; ++a) {
            m.bounds[2 * a] -= 0.4;
            m.bounds[2 * a + 1] += 0.3;
        }
        m.fullResMinSpacing = 0.2;
    }
    return m;
}

// A view over arrays held elsewhere (the ParaView plugin's VTK arrays: stats/model_view.h) renders
// what the model itself renders, bit for bit, for every model with the 1D TF and every model
// with a 2D classification; a RenderCache given a second view of other arrays (other addresses,
// other values, one grid) renders that view's image, not the first's tables; the array checks
// read the view. The borrowed copies sit in one buffer, in an order unlike the model's.
TEST(Render, AViewOfBorrowedArraysRendersAsTheModel) {
    ModelVolume m = tinyModel(93, true);
    m.quantileLevels = {0.0, 0.05, 0.25, 0.3, 0.5, 0.6, 0.75, 0.9, 1.0};
    std::vector<float> store;
    const auto borrow = [&](const ModelVolume& from) {
        store.clear();
        for (auto it = std::rbegin(kModelFileArrays); it != std::rend(kModelFileArrays); ++it)
            store.insert(store.end(), (from.*it->values).begin(), (from.*it->values).end());
        store.insert(store.end(), from.members.begin(), from.members.end());
        ModelView v(from);  // grid and field data; every array replaced below
        std::size_t at = 0;
        for (auto it = std::rbegin(kModelFileArrays); it != std::rend(kModelFileArrays); ++it) {
            const std::size_t n = (from.*it->values).size();
            v.array(*it) = std::span<const float>(store.data() + at, n);
            at += n;
        }
        v.members = std::span<const float>(store.data() + at, from.members.size());
        return v;
    };
    const ModelView view = borrow(m);
    ASSERT_NE(view.mean.data(), m.mean.data());
    RenderSettings s;
    s.width = 30;
    s.height = 26;
    s.camera = defaultCamera(m.bounds, 40.0, 15.0, 1.4);
    s.realizations = 3;
    CounterRng rng(94, 0, 0);
    const TransferFunction2D tf2 = testing::randomTf2(rng, 24, 16, -3.0, 4.0, 0.0, 6.0);
    int rendered2D = 0;
    for (ModelKind kind : allModelKinds()) {
        const ImageRgba a = renderVolume(m, kind, tangleTransferFunction(), s);
        const ImageRgba b = renderVolume(view, kind, tangleTransferFunction(), s);
        ASSERT_EQ(a.rgba, b.rgba) << modelFamily(kind).name;
        // The uniform kinds' 2D frames cost milliseconds a sample (expected_tf2_fast.h): a
        // smaller image for them; uniform-fast is an alias of uniform (the same kernel).
        if (!modelFamily(kind).makeKernel2D || kind == ModelKind::UniformFast) continue;
        RenderSettings s2 = s;
        if (kind == ModelKind::Uniform || kind == ModelKind::UniformExact)
            s2.width = 8, s2.height = 7;
        EXPECT_EQ(renderVolume(m, kind, tf2, s2).rgba, renderVolume(view, kind, tf2, s2).rgba)
            << modelFamily(kind).name;
        ++rendered2D;
    }
    EXPECT_GE(rendered2D, 9);
    // One cache, two views of one grid: the second frame is the second view's.
    ModelVolume other = m;
    for (float& x : other.mean) x += 0.5f;
    const ModelView view1(borrow(m));
    const std::vector<float> keep = std::move(store);  // view1's arrays, at their addresses
    const ModelView view2(borrow(other));
    RenderCache cache;
    const ImageRgba c1 =
        renderVolume(view1, ModelKind::Mean, tangleTransferFunction(), s, nullptr, &cache);
    const ImageRgba c2 =
        renderVolume(view2, ModelKind::Mean, tangleTransferFunction(), s, nullptr, &cache);
    EXPECT_EQ(c1.rgba, renderVolume(m, ModelKind::Mean, tangleTransferFunction(), s).rgba);
    EXPECT_EQ(c2.rgba, renderVolume(other, ModelKind::Mean, tangleTransferFunction(), s).rgba);
    EXPECT_NE(c1.rgba, c2.rgba);
    // checkModelArrays reads the view's arrays.
    std::vector<float> bad(view2.mean.begin(), view2.mean.end());
    bad[5] = std::nanf("");
    ModelView badView = view2;
    badView.mean = bad;
    EXPECT_NO_THROW(checkModelArrays(view2, "the view"));
    try {
        checkModelArrays(badView, "the view");
        ADD_FAILURE() << "a NaN in a borrowed array passed the checks";
    } catch (const UdvrError& e) {
        EXPECT_EQ(std::string(e.what()), "the view: array 'mean' holds NaN at voxel (5, 0, 0)");
    }
}

// Every model's frame against the serial reference marcher over its double kernel, with
// skipping on and off and with 1 and 2 threads: default step and unit (e = ½), e = 1.5 with
// jitter, and e = 2.5 without the early exit; the tangle TF (kinks only) and one with a step;
// a model whose box is wider than its grid. gmm-mc has no per-sample kernel: only the
// invariances are checked for it. Measured (AVX-512): 8.3e−7 against the reference, skipping
// on/off identical, 23 of 57001 pixels left out as ambiguous at the early exit.
TEST(Render, EveryModelMatchesASerialReferenceMarcher) {
    TransferFunction1D stepped = tangleTransferFunction();
    stepped.opacityX = {-3.0, -1.0, 0.1, 0.1, 2.0, 5.0};
    stepped.opacity = {0.2, 0.7, 0.1, 0.9, 0.4, 0.0};
    int compared = 0, ambiguous = 0;
    std::uint64_t skippedSamples = 0;
    for (int config = 0; config < 3; ++config) {
        const ModelVolume m = tinyModel(90 + static_cast<std::uint64_t>(config), config == 1);
        const TransferFunction1D& tf = config == 2 ? stepped : tangleTransferFunction();
        RenderSettings s;
        s.width = 44;
        s.height = 36;
        s.camera = defaultCamera(referenceParams(m, s).bounds, 30.0 + 50.0 * config,
                                 20.0 - 25.0 * config, 1.6);
        s.realizations = 3;
        if (config == 1) {
            s.step = 0.3;
            s.unitDistance = 0.2;
            s.jitterSeed = 9;
        }
        if (config == 2) {
            s.step = 0.225;
            s.unitDistance = 0.09;  // e = 2.5
            s.earlyExit = 1.0;
        }
        for (ModelKind kind : allModelKinds())
            for (bool minMax : {false, true}) {
                if (minMax && kind != ModelKind::Uniform) continue;
                s.uniformMinMax = minMax;
                const std::string what = std::string(modelName(kind)) + " config " +
                                         std::to_string(config) + (minMax ? " minmax" : "");
                RenderStats on, off;
                s.skipEmpty = true;
                setThreadCount(1);
                const ImageRgba a = renderVolume(m, kind, tf, s, &on);
                setThreadCount(2);
                const ImageRgba b = renderVolume(m, kind, tf, s);
                s.skipEmpty = false;
                const ImageRgba c = renderVolume(m, kind, tf, s, &off);
                setThreadCount(0);
                EXPECT_EQ(maxAbsDiff(a, b), 0.0) << what;  // tiles are independent
                // Skipping drops only samples of E[α] = 0 (up to the Gaussian mass beyond 6σ)
                // and regroups the batches: float rounding of the compositing.
                EXPECT_LE(maxAbsDiff(a, c), 1e-6) << what;
                EXPECT_EQ(off.skippedSamples, 0u) << what;
                EXPECT_GT(on.samples + on.skippedSamples, 0u) << what;
                skippedSamples += on.skippedSamples;
                if (kind == ModelKind::GmmMc) continue;
                const ImageRgba ref = referenceFrame(m, kind, tf, s, 1e-4);
                int amb = 0;
                const double dRef = maxAbsDiff(c, ref, &amb);
                ambiguous += amb;
                compared += s.width * s.height - amb;
                // Float lanes against the double kernels (≤ 2e−5 per sample, ~1e−6 typical at
                // |b| ≤ 10, weights summing to ≤ 1) and float compositing against double.
                EXPECT_LE(dRef, 1e-5) << what;
            }
    }
    EXPECT_GT(skippedSamples, 0u);
    EXPECT_LT(ambiguous, compared / 100);
}

}  // namespace
}  // namespace udvr
