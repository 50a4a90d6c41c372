// `uniform-fast` with a 2D TF (detail::expectedTf2UniformLattice, the lattice rule) against the
// converged evaluation (expectedTf2UniformExact) and closed forms. Its Monte Carlo check is
// python/tests/test_reference2d_cli.py.
#include "udvr/classify/expected_tf2_uniform.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include "udvr/classify/expected_tf2_uniform_test_util.h"
#include "udvr/classify/transfer_function_2d.h"

namespace udvr {
namespace {
using testing::Bilinear;
using testing::Case;
using testing::randomCase;
using testing::Raster;

void lattice(const Raster& ras, const Case& c, double out[4]) {
    detail::expectedTf2UniformLattice(ras.rf, ras.r, c.cx, c.cy, c.d.data(),
                                      static_cast<int>(c.d.size()), out);
}
void exact(const Raster& ras, const Case& c, double out[4]) {
    Tf2UniformExactOptions o;
    expectedTf2UniformExact(ras.r, c.cx, c.cy, c.d.data(), static_cast<int>(c.d.size()), 1e-12, o,
                            out);
}

// Each dimension of the lattice is a shifted grid of N points folded by the tent map, so each
// coordinate is uniform on [−1, 1] up to O(1/N²): E[t] = 0, E[t²] = 1/3, E[t⁴] = 1/5 to 1e−4;
// and the generator is the criterion's minimum over the odd a < N.
TEST(Tf2UniformLattice, CoordinatesAreUniformAndTheGeneratorMinimisesTheCriterion) {
    const detail::UniformLattice& l = detail::uniformLattice();
    constexpr int N = detail::UniformLattice::kPoints, D = detail::UniformLattice::kDims;
    for (int j = 0; j < D; ++j) {
        double m1 = 0, m2 = 0, m4 = 0;
        for (int k = 0; k < N; ++k) {
            const double t = l.t[j][k];
            ASSERT_LE(std::abs(t), 1.0);
            m1 += t, m2 += t * t, m4 += t * t * t * t;
        }
        EXPECT_NEAR(m1 / N, 0.0, 1e-4) << "dimension " << j;
        EXPECT_NEAR(m2 / N, 1.0 / 3.0, 1e-4) << "dimension " << j;
        EXPECT_NEAR(m4 / N, 1.0 / 5.0, 1e-4) << "dimension " << j;
    }
    const double chosen = detail::korobovP2(l.generator, N, D);
    for (int a = 3; a < N; a += 2) EXPECT_GE(detail::korobovP2(a, N, D), chosen) << a;
    // A one-dimensional lattice is the grid k/N: P₂ = γ·2π²·(1/N) Σ B₂(k/N) = 2π²/(6N²).
    EXPECT_NEAR(detail::korobovP2(5, N, 1), 19.739208802178716 / (6.0 * N * N), 1e-12);
}

// Random rasters (7×5 random values, so α and c change by O(1) from point to point) and random
// box splines: corners and y-only directions, narrow to several cells wide. Measured (printed):
// max 1.9e−2, RMS 3.0e−3 over these 192 values (N = 1024 points would give 1.05e−2 and 1.5e−3:
// the error falls as ~N^(−1/2) on TFs this rough); bounds about 1.5× above.
TEST(Tf2UniformLattice, IsNearTheExactEvaluation) {
    std::mt19937_64 gen(17);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const int shapes[][2] = {{8, 24}, {8, 0}, {4, 8}, {2, 2}, {1, 0}, {1, 6}};
    double worst = 0.0, sq = 0.0;
    int count = 0;
    for (const auto& sh : shapes)
        for (int rep = 0; rep < 8; ++rep) {
            std::vector<double> v(7 * 5 * 4);
            for (double& x : v) x = u(gen) < 0.2 ? 0.0 : u(gen);
            const Raster ras(7, 5, -1, 1, -0.5, 1.0, [&](double x, double y, double out[4]) {
                const int i = static_cast<int>(std::lround((x + 1) * 3)),
                          j = static_cast<int>(std::lround((y + 0.5) * 4 / 1.5));
                for (int ch = 0; ch < 4; ++ch) out[ch] = v[(j * 7 + i) * 4 + ch];
            });
            const double scale = rep % 2 ? 1.0 : 0.3;
            Case c = randomCase(gen, sh[0], sh[1], 0.3 * scale, 0.4 * scale, 0.1 * scale);
            c.cy += 0.4;
            double a[4], b[4];
            lattice(ras, c, a);
            exact(ras, c, b);
            for (int ch = 0; ch < 4; ++ch) {
                const double e = std::abs(a[ch] - b[ch]);
                worst = std::max(worst, e);
                sq += e * e;
                ++count;
                EXPECT_LE(e, 3e-2) << sh[0] << " corners, " << sh[1] << " y-only, ch " << ch;
            }
        }
    const double rms = std::sqrt(sq / count);
    std::printf("lattice against exact: max %.2e, rms %.2e over %d values\n", worst, rms, count);
    EXPECT_LE(rms, 4.5e-3);
}

// α and c bilinear inside the domain (E[α·c] from the box spline's moments, closed form): the
// integrand is a polynomial of degree ≤ 2 in each t_i; what the lattice leaves is its points'
// correlations between dimensions (|E[t_i t_j]| up to 6.7e−3 for N = 256: the Korobov lattice
// with the smallest largest correlation), through the cross terms: measured 9.7e−6 (9.3e−6 at
// N = 1024; float against double sums 3.7e−8).
TEST(Tf2UniformLattice, BilinearTfIsNearTheClosedForm) {
    std::mt19937_64 gen(23);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    Bilinear tf;
    for (int ch = 0; ch < 4; ++ch) {
        tf.P[ch] = 0.5, tf.Q[ch] = 0.1 * (2 * u(gen) - 1), tf.S[ch] = 0.1 * (2 * u(gen) - 1);
        tf.T[ch] = 0.02 * (2 * u(gen) - 1);
    }
    const Raster ras(9, 13, -4, 4, -6, 6, tf);
    double worst = 0.0;
    for (int trial = 0; trial < 20; ++trial) {
        const Case c = randomCase(gen, 8, 24, 0.5, 0.6, 0.1);
        double got[4], want[4];
        lattice(ras, c, got);
        tf.expectation(c, want);
        for (int ch = 0; ch < 4; ++ch) worst = std::max(worst, std::abs(got[ch] - want[ch]));
    }
    std::printf("lattice, bilinear TF: max %.2e\n", worst);
    EXPECT_LE(worst, 2e-5);
}

// A raster with α at a few random points (colour constant), and its float view with the cells'
// empty distances as the renderer builds them (TransferFunction2D::emptyCellDistances).
struct SparseRaster {
    Raster plain;
    std::vector<float> empty;
    Tf2Raster<float> skip;
    SparseRaster(const std::vector<double>& alpha, int W, int H, double dx, double dy)
        : plain(W, H, -1.5, -1.5 + (W - 1) * dx, 0.25, 0.25 + (H - 1) * dy,
                [&](double x, double y, double out[4]) {
                    const int i = static_cast<int>(std::lround((x + 1.5) / dx)),
                              j = static_cast<int>(std::lround((y - 0.25) / dy));
                    out[0] = 0.3, out[1] = 0.6, out[2] = 0.9, out[3] = alpha[j * W + i];
                }) {
        TransferFunction2D tf;
        tf.width = W, tf.height = H, tf.rgba = plain.rgba;
        empty = tf.emptyCellDistances();
        skip = plain.rf;
        skip.cellEmptyDistance = empty.data();
    }
    // E by the lattice rule without and with the skip.
    void both(const Case& c, double without[4], double with[4]) const {
        lattice(plain, c, without);
        detail::expectedTf2UniformLattice(skip, plain.r, c.cx, c.cy, c.d.data(),
                                          static_cast<int>(c.d.size()), with);
    }
};

// The cell-level skip (a support whose cells all have α = 0 is 0 without a lookup) changes
// nothing: sparse rasters, each case with and without the cells' empty distances.
TEST(Tf2UniformLattice, EmptyCellSkipChangesNothing) {
    std::mt19937_64 gen(29);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    int zeros = 0, nonZeros = 0;
    for (int rep = 0; rep < 30; ++rep) {
        const int W = 24, H = 20;
        std::vector<double> alpha(W * H, 0.0);
        for (int k = 0; k < 3; ++k) alpha[static_cast<int>(u(gen) * W * H)] = 0.2 + 0.8 * u(gen);
        const SparseRaster ras(alpha, W, H, 1.0, 1.0);
        for (int trial = 0; trial < 10; ++trial) {
            Case c = randomCase(gen, 8, 8, 2.0 * u(gen), 2.0 * u(gen), 1.0);
            c.cx = -1.5 + 23 * u(gen), c.cy = 0.25 + 19 * u(gen);
            double a[4], b[4];
            ras.both(c, a, b);
            for (int ch = 0; ch < 4; ++ch) EXPECT_EQ(a[ch], b[ch]) << rep << " " << trial;
            (a[3] == 0.0 ? zeros : nonZeros)++;
        }
    }
    EXPECT_GT(zeros, 20);  // both branches are taken
    EXPECT_GT(nonZeros, 20);
}

// The skip's bound at its edge (review): small rasters, centres on or just beside cell lines and
// outside the domain, one to three directions whose total extent is just under an integer
// number of cells. A bound half a cell too tight (es + 0.5 < d) fails 52 of these 20000 cases.
TEST(Tf2UniformLattice, EmptyCellSkipHoldsAtItsBound) {
    std::mt19937_64 gen(5);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const double near[] = {0, 1e-9, 1e-6, 1e-3, 0.3, 0.5, 0.999, 0.999999, 1 - 1e-12};
    const auto pick = [&] { return near[gen() % 9]; };
    int zeros = 0, mismatches = 0;
    for (int it = 0; it < 20000; ++it) {
        const int W = 2 + static_cast<int>(gen() % 8), H = 2 + static_cast<int>(gen() % 8);
        std::vector<double> alpha(W * H, 0.0);
        for (int k = static_cast<int>(gen() % 3); k > 0; --k) alpha[gen() % (W * H)] = 0.5;
        const double dx = gen() % 2 ? 1.0 : 0.37, dy = gen() % 2 ? 1.0 : 2.3;
        const SparseRaster ras(alpha, W, H, dx, dy);
        const double s0 = static_cast<int>(gen() % (W + 4)) - 2 + (gen() % 2 ? pick() : -pick());
        const double t0 = static_cast<int>(gen() % (H + 4)) - 2 + (gen() % 2 ? pick() : -pick());
        const double total = static_cast<double>(gen() % 6) + (gen() % 2 ? 1 - pick() : u(gen));
        Case c;
        c.cx = -1.5 + s0 * dx, c.cy = 0.25 + t0 * dy;
        for (int i = 0, n = 1 + static_cast<int>(gen() % 3); i < n; ++i) {
            const double w = i == 0 ? total : 0.5 * total * u(gen), f = gen() % 3 ? u(gen) : 0.0;
            c.d.push_back(
                {(gen() % 2 ? 1 : -1) * w * f * dx, (gen() % 2 ? 1 : -1) * w * (1 - f) * dy});
        }
        double a[4], b[4];
        ras.both(c, a, b);
        bool same = true;
        for (int ch = 0; ch < 4; ++ch) same = same && a[ch] == b[ch];
        if (!same && ++mismatches <= 3)
            ADD_FAILURE() << "W " << W << " H " << H << " centre " << s0 << ", " << t0 << ": α "
                          << a[3] << " without the skip, " << b[3] << " with it";
        zeros += a[3] == 0.0;
    }
    EXPECT_EQ(mismatches, 0);
    EXPECT_GT(zeros, 2000);
}

// Non-finite or float-overflowing data: the TF2 lookup at the centre, as the exact evaluation.
TEST(Tf2UniformLattice, NonFiniteDataIsALookup) {
    const Raster ras(3, 3, 0, 1, 0, 1, [](double x, double y, double v[4]) {
        v[0] = x, v[1] = y, v[2] = 0.5, v[3] = 0.25 + 0.5 * x * y;
    });
    const double nan = std::numeric_limits<double>::quiet_NaN();
    for (const Case& c : {Case{0.5, 0.5, {{nan, 0.1}}}, Case{0.5, 0.5, {{0.1, 1e40}}},
                          Case{0.5, nan, {{0.1, 0.1}}}}) {
        double got[4], want[4];
        lattice(ras, c, got);
        tf2At<double>(ras.r, c.cx, c.cy, true, want);
        for (int ch = 0; ch < 4; ++ch) EXPECT_EQ(got[ch], want[ch]);
    }
}

}  // namespace
}  // namespace udvr
