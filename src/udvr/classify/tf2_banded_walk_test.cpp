// The banded segment walk (Tf2Raster::bandPrefix, detail::bandedWalk: the axis a segment crosses
// fewer lines of walked, the other's cells from prefix tables) against the cell-by-cell walk it
// replaces (detail::segmentWalk over every raster line crossed, kept as the reference), in
// double to 1e−6 (rounding, measured ~1e−13), and its float and lane bodies against that walk,
// on random rough TF2s and random segments: across and beyond the domain, on and near raster
// lines, axis-parallel, zero-length, long and shallow over wide rasters.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <tuple>
#include <vector>

#include "udvr/classify/classify_test_util.h"
#include "udvr/classify/expected_tf2.h"
#include "udvr/classify/model_families.h"
#include "udvr/classify/transfer_function_2d.h"

namespace udvr {
namespace {

using testing::randomTf2;

/// A TF2's views: `walk` the cell-by-cell walk (no runs, no tables), `banded` the same with the
/// prefix tables; `setup.fast` the float view as the kernels get it when they walk banded.

struct BandedViews {
    Tf2Rasters setup;                         // its float view walks banded
    Tf2Raster<double> walk, banded, clipped;  // clipped: banded, skipping cells with α = 0
    std::vector<double> tables;
    explicit BandedViews(const TransferFunction2D& t)
        : setup(t, Tf2SegmentWalk::banded),
          walk(setup.exact),
          banded(setup.exact),
          clipped(setup.exact) {
        walk.cellRun = nullptr;
        walk.rowPrefix = walk.rowSameUpTo = nullptr;
        tables = t.bandPrefixMoments();
        banded.bandPrefix = clipped.bandPrefix = tables.data();
        clipped.bandCells = setup.fast.bandCells;
        for (int k = 0; k < 4; ++k) clipped.opaqueBox[k] = setup.fast.opaqueBox[k];
    }
};

/// The cell-by-cell walk's mean along one segment (the reference).
void cellWalkMean(const Tf2Raster<double>& r, double xa, double ya, double xb, double yb,
                  double out[4]) {
    EXPECT_EQ(r.bandPrefix, nullptr);
    EXPECT_EQ(r.cellRun, nullptr);
    detail::OneSegment<double> one{xa, ya, xb, yb};
    detail::segmentWalk<false, double>(r, one, true, out);
}

/// A random segment (data units) over a raster of w × h points spanning [0, w − 1] × [0, h − 1]
/// (raster coordinates are data coordinates): kind 0 anywhere in a margin around the domain,
/// 1 along a row, 2 along a column, 3 zero-length, 4 ends on raster lines, 5 along a raster
/// line, 6 near raster lines (1e−7 off), 7 long and shallow, 8 long and steep, 9 far outside.
std::array<double, 4> randomSegment(CounterRng& rng, int w, int h, int kind) {
    const auto x = [&] { return -3.0 + (w + 5.0) * rng.uniform(); };
    const auto y = [&] { return -3.0 + (h + 5.0) * rng.uniform(); };
    const auto lineX = [&] { return std::floor(rng.uniform() * w); };
    const auto lineY = [&] { return std::floor(rng.uniform() * h); };
    std::array<double, 4> p{x(), y(), x(), y()};
    switch (kind) {
        case 1:
            p[3] = p[1];
            break;
        case 2:
            p[2] = p[0];
            break;
        case 3:
            p[2] = p[0], p[3] = p[1];
            break;
        case 4:
            p = {lineX(), lineY(), lineX(), lineY()};
            break;
        case 5:
            if (rng.uniform() < 0.5)
                p[0] = p[2] = lineX();
            else
                p[1] = p[3] = lineY();
            break;
        case 6: {
            const double e = 1e-7 * (rng.uniform() < 0.5 ? -1 : 1);
            p = {lineX() + e, lineY() - e, lineX() - e, lineY() + e};
            if (rng.uniform() < 0.5) p[2] = p[0] + 3e-7;
            break;
        }
        case 7:
            p = {-2.0, y(), w + 1.0, p[1] + (rng.uniform() - 0.5) * 4.0};
            break;
        case 8:
            p = {x(), -2.0, p[0] + (rng.uniform() - 0.5) * 4.0, h + 1.0};
            break;
        case 9:
            p = {-50.0 - rng.uniform(), y(), -40.0, y()};
            break;
        default:
            break;
    }
    if (rng.uniform() < 0.5) std::swap(p[0], p[2]), std::swap(p[1], p[3]);
    return p;
}

/// Rough random TF2s (every point independent, a quarter with α = 0), plus blocks of α = 0.
TransferFunction2D roughTf2(CounterRng& rng, int w, int h, bool holes) {
    TransferFunction2D t = randomTf2(rng, w, h, 0.0, w - 1.0, 0.0, h - 1.0);
    if (holes)
        for (int j = 0; j < h; ++j)
            for (int i = 0; i < w; ++i)
                if ((i / 7 + j / 5) % 3 == 0)
                    t.rgba[(static_cast<std::size_t>(j) * w + i) * 4 + 3] = 0;
    return t;
}

TEST(Tf2BandedWalk, MatchesTheCellByCellWalkInDouble) {
    CounterRng rng(33, 1, 0);
    double worst = 0;
    int tabled = 0;
    for (const auto& [w, h, holes] :
         {std::tuple{7, 5, false}, std::tuple{40, 33, true}, std::tuple{2, 2, false},
          std::tuple{300, 4, false}, std::tuple{4, 300, true}, std::tuple{256, 256, true}}) {
        const TransferFunction2D t = roughTf2(rng, w, h, holes);
        const BandedViews v(t);
        for (int trial = 0; trial < 3000; ++trial) {
            const auto p = randomSegment(rng, w, h, trial % 10);
            double want[4], got[4], skipping[4];
            cellWalkMean(v.walk, p[0], p[1], p[2], p[3], want);
            tf2MeanAlongSegment<double>(v.banded, p[0], p[1], p[2], p[3], true, got);
            tf2MeanAlongSegment<double>(v.clipped, p[0], p[1], p[2], p[3], true, skipping);
            const double lines = std::min(std::abs(p[2] - p[0]), std::abs(p[3] - p[1]));
            tabled += lines >= 2 && std::max(std::abs(p[2] - p[0]), std::abs(p[3] - p[1])) >= 3;
            for (int ch = 0; ch < 4; ++ch) {
                const double d =
                    std::max(std::abs(got[ch] - want[ch]), std::abs(skipping[ch] - want[ch]));
                worst = std::max(worst, d);
                ASSERT_LE(d, 1e-6) << w << "x" << h << " trial " << trial << " ch " << ch << " ("
                                   << p[0] << ", " << p[1] << ") → (" << p[2] << ", " << p[3]
                                   << "): " << got[ch] << " vs " << want[ch];
            }
        }
    }
    std::printf("banded vs cell-by-cell walk, double: max |Δ| %.3g (%d segments over tables)\n",
                worst, tabled);
    EXPECT_GT(tabled, 1000);  // the tables were exercised
    EXPECT_LE(worst, 1e-10);
}

// A TF2 that is the same bilinear function everywhere (corners from one plane per channel) has a
// closed-form segment mean; the tables' recentring is checked there far from the origin.
TEST(Tf2BandedWalk, LinearTf2GivesTheClosedFormFarFromTheOrigin) {
    const int w = 1024, h = 1024;
    TransferFunction2D t;
    t.width = w, t.height = h, t.x0 = 0, t.x1 = w - 1, t.y0 = 0, t.y1 = h - 1;
    const auto f = [&](int ch, double s, double u) {
        return 0.1 + 0.2 * ch * 0.1 + (0.3 * s / (w - 1) + 0.4 * u / (h - 1)) * (ch == 3 ? 1 : 0.5);
    };
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i)
            for (int ch = 0; ch < 4; ++ch) t.rgba.push_back(static_cast<float>(f(ch, i, j)));
    std::vector<double> tables = t.bandPrefixMoments();
    Tf2Raster<double> r;
    r.width = w, r.height = h, r.rgba = t.rgba.data(), r.bandPrefix = tables.data();
    CounterRng rng(33, 2, 0);
    double worst = 0;
    for (int trial = 0; trial < 2000; ++trial) {
        // Short and long segments near the far corner, steep and shallow.
        const double xa = 900 + 120 * rng.uniform(), ya = 900 + 120 * rng.uniform();
        const double len = trial % 2 ? 3.0 : 100.0;
        const double xb = std::clamp(xa + len * (rng.uniform() - 0.5), 0.0, w - 1.0);
        const double yb = std::clamp(ya + len * (rng.uniform() - 0.5), 0.0, h - 1.0);
        double got[4];
        tf2MeanAlongSegment<double>(r, xa, ya, xb, yb, true, got);
        // α and c linear along the segment (the raster is exact for them up to float rounding
        // of the points): mean of α·c = ∫ (α_a + u·Δα)(c_a + u·Δc) du.
        double want[4];
        const double a0 = f(3, xa, ya), a1 = f(3, xb, yb);
        want[3] = 0.5 * (a0 + a1);
        for (int ch = 0; ch < 3; ++ch) {
            const double c0 = f(ch, xa, ya), c1 = f(ch, xb, yb);
            want[ch] =
                a0 * c0 + 0.5 * (a0 * (c1 - c0) + (a1 - a0) * c0) + (a1 - a0) * (c1 - c0) / 3;
        }
        for (int ch = 0; ch < 4; ++ch) worst = std::max(worst, std::abs(got[ch] - want[ch]));
    }
    std::printf("banded walk on a linear 1024² TF2 near (1000, 1000): max |Δ| %.3g\n", worst);
    EXPECT_LE(worst, 1e-6);  // the points' float rounding: ≤ 6e−8 per point
}

// The tables' memory bound (kMaxTf2BandPrefixPoints, 2^18 points = 512²: 84 MiB): a raster at
// the bound gets them, one row more walks cell by cell (a TF2 edit in serve allocates no more).
// Without Tf2SegmentWalk::banded (renders) no raster gets them.
TEST(Tf2BandedWalk, TablesStopAtTheirPointBound) {
    CounterRng rng(33, 9, 0);
    for (const auto& [w, h, tables] : {std::tuple{512, 512, true}, std::tuple{512, 513, false}}) {
        ASSERT_EQ(static_cast<std::size_t>(w) * h <= kMaxTf2BandPrefixPoints, tables);
        const TransferFunction2D t = roughTf2(rng, w, h, false);
        const Tf2Rasters r(t, Tf2SegmentWalk::banded);
        EXPECT_EQ(r.fast.bandPrefix != nullptr, tables) << w << "x" << h;
        EXPECT_LE(r.bandPrefix.size() * sizeof(double), std::size_t{84} << 20);
        const Tf2Rasters cells(t);
        EXPECT_EQ(cells.fast.bandPrefix, nullptr);
        EXPECT_TRUE(cells.bandPrefix.empty() && cells.bandCells.empty());
    }
}

TEST(Tf2BandedWalk, FloatAndLanesMatchTheDoubleCellWalk) {
    CounterRng rng(33, 3, 0);
    for (const auto& [w, h] : {std::pair{40, 33}, std::pair{256, 256}, std::pair{5, 200}}) {
        TransferFunction2D t = roughTf2(rng, w, h, true);
        // A data domain that is not the raster's (the kernels' coordinates are scaled).
        t.x0 = -7.0, t.x1 = 35.0, t.y0 = 0.0, t.y1 = 60.0;
        const BandedViews v(t);
        ASSERT_NE(v.setup.fast.bandPrefix, nullptr);
        const auto data = [&](const std::array<double, 4>& p) {
            return std::array<double, 4>{
                t.x0 + p[0] * (t.x1 - t.x0) / (w - 1), t.y0 + p[1] * (t.y1 - t.y0) / (h - 1),
                t.x0 + p[2] * (t.x1 - t.x0) / (w - 1), t.y0 + p[3] * (t.y1 - t.y0) / (h - 1)};
        };
        double worstLanes = 0, worstFloat = 0;
        for (int trial = 0; trial < 300; ++trial) {
            lanes::Vf p[4];
            for (int l = 0; l < lanes::kWidth; ++l) {
                const auto q = data(randomSegment(rng, w, h, (trial + l) % 10));
                for (int c = 0; c < 4; ++c) p[c][l] = static_cast<float>(q[c]);
            }
            lanes::Vf got[4];
            tf2MeanAlongSegment<lanes::Vf>(v.setup.fast, p[0], p[1], p[2], p[3],
                                           lanes::allTrue<lanes::Vf>(), got);
            for (int l = 0; l < lanes::kWidth; ++l) {
                double want[4];
                float one[4];
                cellWalkMean(v.walk, p[0][l], p[1][l], p[2][l], p[3][l], want);
                tf2MeanAlongSegment<float>(v.setup.fast, p[0][l], p[1][l], p[2][l], p[3][l], true,
                                           one);
                for (int ch = 0; ch < 4; ++ch) {
                    worstLanes = std::max(worstLanes, std::abs(got[ch][l] - want[ch]));
                    worstFloat = std::max(worstFloat, std::abs(one[ch] - want[ch]));
                }
            }
        }
        std::printf("%dx%d: lanes %.3g, float %.3g against the double cell walk\n", w, h,
                    worstLanes, worstFloat);
        // Float coordinates: raster positions to ~6e−8 × 256 on these rough rasters.
        EXPECT_LE(worstLanes, 5e-5);
        EXPECT_LE(worstFloat, 5e-5);
    }
}

// quantile-range's polylines through the pool of a batch's segments (PooledPolylineSegments,
// with and without parts) walk banded as well.
TEST(Tf2BandedWalk, PooledPolylinesMatchTheirSegmentsCellWalks) {
    CounterRng rng(33, 4, 0);
    TransferFunction2D t = roughTf2(rng, 256, 256, true);
    t.x0 = -7.0, t.x1 = 35.0, t.y0 = 0.0, t.y1 = 60.0;
    const BandedViews v(t);
    double worst = 0;
    for (const int count : {2, 3, 9, 17}) {
        const QuantileLevels levels{nullptr, 0};
        std::vector<lanes::Vf> x(count), g(count);
        for (int l = 0; l < lanes::kWidth; ++l) {
            double xv = -9.0 + 46.0 * rng.uniform(), gv = 62.0 * rng.uniform();
            for (int j = 0; j < count; ++j) {
                xv += 3.0 * (rng.uniform() - 0.3);
                gv = std::abs(gv + 10.0 * (rng.uniform() - 0.5));
                x[j][l] = static_cast<float>(xv);
                g[j][l] = static_cast<float>(gv);
            }
        }
        const lanes::Mask live = lanes::iota() != 5;
        lanes::Vf got[4];
        expectedTf2QuantileRange<lanes::Vf>(v.setup.fast, x.data(), g.data(), count, levels, live,
                                            got);
        for (int l = 0; l < lanes::kWidth; ++l) {
            if (!live[l]) continue;
            double want[4] = {0, 0, 0, 0};
            for (int j = 1; j < count; ++j) {
                double m[4];
                cellWalkMean(v.walk, x[j - 1][l], g[j - 1][l], x[j][l], g[j][l], m);
                for (int ch = 0; ch < 4; ++ch) want[ch] += m[ch] / (count - 1);
            }
            for (int ch = 0; ch < 4; ++ch) worst = std::max(worst, std::abs(got[ch][l] - want[ch]));
        }
    }
    std::printf("pooled polylines, lanes: max |Δ| %.3g against the double cell walk\n", worst);
    EXPECT_LE(worst, 5e-5);
}

}  // namespace
}  // namespace udvr
