// The reconstructions of reconstruct/ against the definitions of SPEC §3 written out here: the
// trilinear weights w_c = Π_axis (1 − f or f) of each corner, Σ w_c v_c, Σ w_c² σ_c², rank-wise
// π/μ/σ, the boundaries of Eq. 2 — for every value type (double, float, the lanes of a batch).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <vector>

#include "udvr/reconstruct/cell.h"
#include "udvr/reconstruct/gaussian_interp.h"
#include "udvr/reconstruct/gmm_ordered.h"
#include "udvr/reconstruct/quantile_interp.h"
#include "udvr/util/random.h"

namespace udvr {
namespace {

constexpr std::array<int, 3> kDims{5, 4, 3};

// A point of the grid and its 8 corners with weights, computed here from the definition.
struct Point {
    float x, y, z;
    std::int64_t corner[8];
    double weight[8];
};
Point referencePoint(CounterRng& rng) {
    Point p{};
    const float v[3] = {static_cast<float>(rng.uniform() * (kDims[0] - 1)),
                        static_cast<float>(rng.uniform() * (kDims[1] - 1)),
                        static_cast<float>(rng.uniform() * (kDims[2] - 1))};
    p.x = v[0], p.y = v[1], p.z = v[2];
    int base[3];
    double frac[3];
    for (int a = 0; a < 3; ++a) {
        base[a] = std::min(static_cast<int>(v[a]), kDims[a] - 2);
        frac[a] = static_cast<double>(v[a]) - base[a];
    }
    for (int c = 0; c < 8; ++c) {
        const int o[3] = {c & 1, (c >> 1) & 1, (c >> 2) & 1};
        p.corner[c] =
            (base[0] + o[0]) + kDims[0] * ((base[1] + o[1]) + kDims[1] * (base[2] + o[2]));
        p.weight[c] = 1.0;
        for (int a = 0; a < 3; ++a) p.weight[c] *= o[a] ? frac[a] : 1.0 - frac[a];
    }
    return p;
}

std::vector<float> randomValues(CounterRng& rng, std::size_t n, double lo, double hi) {
    std::vector<float> v(n);
    for (float& x : v) x = static_cast<float>(lo + (hi - lo) * rng.uniform());
    return v;
}

constexpr std::size_t kVoxels = static_cast<std::size_t>(kDims[0]) * kDims[1] * kDims[2];

TEST(Reconstruct, TrilinearAndGaussianMatchTheirDefinition) {
    CounterRng rng(11, 0, 0);
    const CellGeometry g(kDims);
    const std::vector<float> mean = randomValues(rng, kVoxels, -50, 50);
    const std::vector<float> sd = randomValues(rng, kVoxels, 0, 3);
    std::vector<Point> points;
    for (int i = 0; i < 3 * lanes::kWidth; ++i) points.push_back(referencePoint(rng));
    for (const Point& p : points) {
        double mu = 0, var = 0;
        for (int c = 0; c < 8; ++c) {
            mu += p.weight[c] * mean[p.corner[c]];
            var += p.weight[c] * p.weight[c] * sd[p.corner[c]] * sd[p.corner[c]];
        }
        const Cell<double> cd = cellAt<double>(g, p.x, p.y, p.z);
        EXPECT_NEAR(trilinear(g, mean.data(), 1, cd, true), mu, 1e-5);  // float fractions
        double m, s;
        gaussianAt(g, mean.data(), sd.data(), cd, true, m, s);
        EXPECT_NEAR(m, mu, 1e-5);
        EXPECT_NEAR(s, std::sqrt(var), 1e-6);
        const Cell<float> cf = cellAt<float>(g, p.x, p.y, p.z);
        float mf, sf;
        gaussianAt(g, mean.data(), sd.data(), cf, true, mf, sf);
        EXPECT_NEAR(mf, mu, 1e-4);  // float rounding of |μ| ≤ 50
        EXPECT_NEAR(sf, std::sqrt(var), 1e-5);
    }
    // The lanes of a batch, one dead lane: the same values, 0 in the dead lane.
    for (std::size_t b = 0; b + lanes::kWidth <= points.size(); b += lanes::kWidth) {
        lanes::Vf x, y, z;
        for (int l = 0; l < lanes::kWidth; ++l) {
            x[l] = points[b + l].x, y[l] = points[b + l].y, z[l] = points[b + l].z;
        }
        const lanes::Mask live = lanes::iota() != 1;
        const Cell<lanes::Vf> c = cellAt<lanes::Vf>(g, x, y, z);
        lanes::Vf m, s;
        gaussianAt(g, mean.data(), sd.data(), c, live, m, s);
        for (int l = 0; l < lanes::kWidth; ++l) {
            double mu, sigma;
            gaussianAt(g, mean.data(), sd.data(), laneCell(c, l), true, mu, sigma);
            if (l == 1) {
                EXPECT_EQ(m[l], 0.f);
                EXPECT_EQ(s[l], 0.f);
                continue;
            }
            EXPECT_NEAR(m[l], mu, 1e-4);
            EXPECT_NEAR(s[l], sigma, 1e-5);
        }
    }
}

TEST(Reconstruct, GmmOrderedInterpolatesEachRankAndNormalises) {
    CounterRng rng(12, 0, 0);
    const CellGeometry g(kDims);
    constexpr int K = 3;
    std::vector<float> gmm(kVoxels * 3 * K);
    for (std::size_t v = 0; v < kVoxels; ++v)
        for (int k = 0; k < K; ++k) {
            gmm[v * 3 * K + k] = static_cast<float>(rng.uniform());
            gmm[v * 3 * K + K + k] = static_cast<float>(10 * k + rng.uniform());
            gmm[v * 3 * K + 2 * K + k] = static_cast<float>(0.1 + rng.uniform());
        }
    for (int i = 0; i < 40; ++i) {
        const Point p = referencePoint(rng);
        double pi[K] = {}, mu[K] = {}, sg[K] = {}, total = 0;
        for (int c = 0; c < 8; ++c)
            for (int k = 0; k < K; ++k) {
                const float* v = &gmm[p.corner[c] * 3 * K];
                pi[k] += p.weight[c] * v[k];
                mu[k] += p.weight[c] * v[K + k];
                sg[k] += p.weight[c] * v[2 * K + k];
            }
        for (double x : pi) total += x;
        double gp[K], gm[K], gs[K];
        const double t =
            gmmOrderedAt(g, gmm.data(), K, cellAt<double>(g, p.x, p.y, p.z), true, gp, gm, gs);
        EXPECT_NEAR(t, total, 1e-6);
        for (int k = 0; k < K; ++k) {
            EXPECT_NEAR(gp[k], pi[k] / total, 1e-6);
            EXPECT_NEAR(gm[k], mu[k], 1e-5);
            EXPECT_NEAR(gs[k], sg[k], 1e-6);
        }
    }
}

// rows4 (4 floats per voxel) against the definition, and bit for bit against trilinear of each
// float (the order of the lerps is the same): every pattern of dead lanes in a pair, points on
// the last planes, and grids one point wide along x (x-neighbours not adjacent).
TEST(Reconstruct, FourFloatRowsAreTrilinearBitForBit) {
    CounterRng rng(17, 0, 0);
    for (const std::array<int, 3> dims :
         {kDims, std::array<int, 3>{1, 4, 3}, std::array<int, 3>{2, 2, 2}}) {
        const CellGeometry g(dims);
        const std::size_t voxels = static_cast<std::size_t>(dims[0]) * dims[1] * dims[2];
        const std::vector<float> rows = randomValues(rng, 4 * voxels, -50, 50);
        for (int round = 0; round < 64; ++round) {
            lanes::Vf p[3];  // a quarter of the coordinates on the last plane of their axis
            for (int l = 0; l < lanes::kWidth; ++l)
                for (int a = 0; a < 3; ++a)
                    p[a][l] = rng.uniform() < 0.25
                                  ? static_cast<float>(dims[a] - 1)
                                  : static_cast<float>(rng.uniform() * (dims[a] - 1));
            const lanes::Vf &x = p[0], &y = p[1], &z = p[2];
            Cell<lanes::Vf> cells = cellAt<lanes::Vf>(g, x, y, z);
            // Round 0: all live; then random masks (pairs with none, one or both alive), the
            // dead lanes' cells 2^28 voxels outside the array (reading them would fault).
            lanes::Mask live = lanes::iota() >= 0;
            if (round > 0)
                for (int l = 0; l < lanes::kWidth; ++l) {
                    live[l] = rng.uniform() < 0.6 ? -1 : 0;
                    if (!live[l]) cells.base[l] = (1 << 28) + l;
                }
            lanes::Vf out[4];
            rows4(g, rows.data(), cells, live, out);
            for (int k = 0; k < 4; ++k) {
                const lanes::Vf want = trilinear(g, rows.data() + k, 4, cells, live);
                for (int l = 0; l < lanes::kWidth; ++l) {
                    if (!live[l]) {
                        ASSERT_EQ(out[k][l], 0.f);
                        continue;
                    }
                    ASSERT_EQ(out[k][l], want[l]) << k << " " << l;
                    const Cell<double> c = cellAt<double>(g, x[l], y[l], z[l]);
                    double w[8], sum = 0;
                    trilinearWeights(c, w);
                    for (int corner = 0; corner < 8; ++corner)
                        sum += w[corner] * rows[4 * cornerVoxel(g, c.base, corner) + k];
                    ASSERT_NEAR(out[k][l], sum, 1e-4);
                }
            }
        }
    }
}

// Eq. 2 for q from 1 to beyond two blocks of lanes: boundaryAt, widthAt and the batch's rows.
TEST(Reconstruct, QuantileBoundariesAndWidthsFollowEq2) {
    CounterRng rng(13, 0, 0);
    const CellGeometry g(kDims);
    for (int q : {1, 3, 7, 8, 15, 16, 2 * lanes::kWidth - 1, 40}) {
        const int stride = q + 1;
        std::vector<float> b(kVoxels * stride);
        for (std::size_t v = 0; v < kVoxels; ++v) {  // sorted, with ties (zero widths)
            double x = 1000 * rng.uniform() - 500;
            for (int j = 0; j <= q; ++j) {
                if (rng.uniform() > 0.2) x += 3 * rng.uniform();
                b[v * stride + j] = static_cast<float>(x);
            }
        }
        std::vector<Point> points;
        for (int i = 0; i < lanes::kWidth; ++i) points.push_back(referencePoint(rng));
        lanes::Vf x, y, z;
        for (int l = 0; l < lanes::kWidth; ++l) {
            x[l] = points[l].x, y[l] = points[l].y, z[l] = points[l].z;
        }
        const Cell<lanes::Vf> cells = cellAt<lanes::Vf>(g, x, y, z);
        const lanes::Mask live = lanes::iota() != 2;
        const bool rows = stride <= kMaxRowBoundaries;
        std::vector<lanes::Vf> rb(kMaxRowBoundaries), rw(kMaxRowBoundaries);
        if (rows) boundaryRows(g, b.data(), stride, 0, stride, cells, live, rb.data(), rw.data());
        for (int l = 0; l < lanes::kWidth; ++l) {
            const Point& p = points[l];
            const Cell<double> c = cellAt<double>(g, p.x, p.y, p.z);
            for (int j = 0; j <= q; ++j) {
                double want = 0, wantWidth = 0;
                for (int k = 0; k < 8; ++k) {
                    const float* v = &b[p.corner[k] * stride];
                    want += p.weight[k] * v[j];
                    if (j < q) wantWidth += p.weight[k] * (static_cast<double>(v[j + 1]) - v[j]);
                }
                // |b| ≤ ~600 in float fractions: ~1e−4; the lanes in float: ~2e−4.
                EXPECT_NEAR(boundaryAt<double>(g, b.data(), stride, j, c, true), want, 2e-4);
                if (j < q) {
                    const double width = widthAt<double>(g, b.data(), stride, j, c, true);
                    EXPECT_NEAR(width, wantWidth, 1e-5);
                    EXPECT_GE(width, 0.0);
                }
                const lanes::Vf lane = boundaryAt<lanes::Vf>(g, b.data(), stride, j, cells, live);
                if (l == 2) {  // the dead lane
                    EXPECT_EQ(lane[l], 0.f);
                    if (rows) {
                        EXPECT_EQ(rb[j][l], 0.f);
                    }
                    continue;
                }
                EXPECT_NEAR(lane[l], want, 3e-4) << q << " " << j;
                if (!rows) continue;
                EXPECT_NEAR(rb[j][l], want, 3e-4) << q << " " << j;
                // One arithmetic (interpolatedBoundary): the rows are the gathered lanes' values
                // to the bit, but for a last boundary alone in its block (b_{q−1} + w_{q−1}).
                if (j < q || q % lanes::kWidth != 0) {
                    EXPECT_EQ(rb[j][l], lane[l]) << q << " " << j;
                }
                if (j < q) {
                    EXPECT_NEAR(rw[j][l], wantWidth, 1e-4) << q << " " << j;
                    EXPECT_GE(rw[j][l], 0.f);
                    const lanes::Vf width = widthAt<lanes::Vf>(g, b.data(), stride, j, cells, live);
                    EXPECT_EQ(rw[j][l], width[l]) << q << " " << j;
                }
            }
        }
    }
}

}  // namespace
}  // namespace udvr
