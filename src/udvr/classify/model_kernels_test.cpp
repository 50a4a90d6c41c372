// Every model's kernel against Monte Carlo of its own definition (SPEC §3–4), plus edge cases,
// and the lane (CPU batch) and float (one GPU thread) bodies of every kernel against its double
// body.
#include "udvr/classify/model_kernels.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <string>

#include "udvr/classify/classify_test_util.h"
#include "udvr/classify/kernel_test_util.h"
#include "udvr/classify/model_families.h"
#include "udvr/classify/tf_presets.h"
#include "udvr/data/synthetic.h"

namespace udvr {
namespace {

constexpr int kMc = 100000;

Rgba classify(const ModelVolume& m, ModelKind kind, const TransferFunction1D& tf, float x, float y,
              float z, const ClassifyOptions& o = {}) {
    Rgba out;
    withKernel(m, kind, tf, o, [&](const auto& k) { out = classifyExact(k, x, y, z); });
    return out;
}

using testing::RefCell;
using testing::refCell;

// |kernel − MC| ≤ 5 standard errors (+ float rounding of the result).
void expectMc(const Rgba& got, const TransferFunction1D& tf, const std::function<double()>& draw,
              const char* what) {
    double mean[4], se[4];
    testing::monteCarlo(tf, kMc, draw, mean, se);
    const double v[4] = {got.r, got.g, got.b, got.a};
    for (int ch = 0; ch < 4; ++ch)
        EXPECT_NEAR(v[ch], mean[ch], 5 * se[ch] + 1e-6) << what << " channel " << ch;
}

// Quantile function of voxel v at u ∈ [0,1]: piecewise linear through (j/q, b_j).
double voxelQuantile(const float* b, int q, double u) {
    const double pos = u * q;
    int j = static_cast<int>(pos);
    if (j >= q) return b[q];
    const double t = pos - j;
    return b[j] + t * (b[j + 1] - b[j]);
}

struct Case {
    ModelVolume model;
    TransferFunction1D tf;
    float p[3];
    RefCell cell;
};

Case makeCase(std::uint64_t seed, int q) {
    CounterRng rng(seed, 1, 0);
    Case c{testing::randomModel(rng, {3, 3, 2}, q), {}, {}, {}};
    const auto r = modelDataRange(c.model);
    // The TF covers part of the data range sometimes (clamping), all of it other times.
    const double lo = r.first + (seed % 2 ? 0.3 : -0.1) * (r.second - r.first);
    c.tf = testing::randomTf(rng, lo, r.second);
    for (int a = 0; a < 3; ++a)
        c.p[a] = static_cast<float>(rng.uniform() * (c.model.grid.dims[a] - 1));
    c.cell = refCell(c.model.grid.dims, c.p[0], c.p[1], c.p[2]);
    return c;
}

class KernelMc : public ::testing::TestWithParam<int> {};

TEST_P(KernelMc, EveryModelMatchesMonteCarloOfItsDefinition) {
    const int q = 8;
    Case c = makeCase(100 + static_cast<std::uint64_t>(GetParam()), q);
    const ModelVolume& m = c.model;
    const RefCell& cell = c.cell;
    CounterRng rng(999, static_cast<std::uint64_t>(GetParam()), 0);
    auto at = [&](ModelKind k) { return classify(m, k, c.tf, c.p[0], c.p[1], c.p[2]); };

    // mean: deterministic.
    {
        double v = 0;
        for (int k = 0; k < 8; ++k) v += cell.weight[k] * m.mean[cell.corner[k]];
        const Rgba ref = c.tf.classify(v), got = at(ModelKind::Mean);
        EXPECT_NEAR(got.a, ref.a, 1e-5);
        EXPECT_NEAR(got.r, ref.r, 1e-5);
    }
    // uniform: independent U[μ−√3σ, μ+√3σ] per corner.
    expectMc(
        at(ModelKind::Uniform), c.tf,
        [&] {
            double x = 0;
            for (int k = 0; k < 8; ++k) {
                const std::size_t v = cell.corner[k];
                const double h = std::sqrt(3.0) * m.stddev[v];
                x += cell.weight[k] * (m.mean[v] - h + 2 * h * rng.uniform());
            }
            return x;
        },
        "uniform");
    // gaussian: independent N(μ, σ²) per corner.
    expectMc(
        at(ModelKind::Gaussian), c.tf,
        [&] {
            double x = 0;
            for (int k = 0; k < 8; ++k) {
                const std::size_t v = cell.corner[k];
                x += cell.weight[k] * (m.mean[v] + m.stddev[v] * rng.normal());
            }
            return x;
        },
        "gaussian");
    // gmm-ordered: the mixture of rank-wise interpolated components.
    {
        const int K = m.gmmComponents;
        std::vector<double> pi(K), mu(K), sg(K);
        double ps = 0;
        for (int j = 0; j < K; ++j) {
            for (int k = 0; k < 8; ++k) {
                const float* g = m.gmmAt(cell.corner[k]);
                pi[j] += cell.weight[k] * g[j];
                mu[j] += cell.weight[k] * g[K + j];
                sg[j] += cell.weight[k] * g[2 * K + j];
            }
            ps += pi[j];
        }
        expectMc(
            at(ModelKind::GmmOrdered), c.tf,
            [&] {
                double u = rng.uniform() * ps;
                int j = 0;
                while (j < K - 1 && u >= pi[j]) u -= pi[j++];
                return mu[j] + sg[j] * rng.normal();
            },
            "gmm-ordered");
    }
    // Quantile models: X = Σ_c w_c Q_c(U), one U for all corners (Eq. 2), restricted to the
    // population's probability range for the quartile views.
    auto quantileDraw = [&](double u0, double u1) {
        return [&, u0, u1] {
            const double u = u0 + (u1 - u0) * rng.uniform();
            double x = 0;
            for (int k = 0; k < 8; ++k)
                x += cell.weight[k] * voxelQuantile(m.quantilesAt(cell.corner[k]), q, u);
            return x;
        };
    };
    expectMc(at(ModelKind::QuantileRange), c.tf, quantileDraw(0, 1), "quantile-range");
    expectMc(at(ModelKind::QuartileLower), c.tf, quantileDraw(0, 0.25), "quartile-lower");
    expectMc(at(ModelKind::QuartileMiddle), c.tf, quantileDraw(0.25, 0.75), "quartile-middle");
    expectMc(at(ModelKind::QuartileUpper), c.tf, quantileDraw(0.75, 1), "quartile-upper");
    // iqr: uniform on [b(.25), b(.75)] interpolated.
    expectMc(
        at(ModelKind::Iqr), c.tf,
        [&] {
            double lo = 0, hi = 0;
            for (int k = 0; k < 8; ++k) {
                lo += cell.weight[k] * m.iqr[2 * cell.corner[k]];
                hi += cell.weight[k] * m.iqr[2 * cell.corner[k] + 1];
            }
            return lo + (hi - lo) * rng.uniform();
        },
        "iqr");
    // quantile-mean(-mass): discrete distribution on the midpoints m_j with weights p_j.
    for (bool density : {true, false}) {
        std::vector<double> b(q + 1), w(q);
        for (int j = 0; j <= q; ++j)
            for (int k = 0; k < 8; ++k) b[j] += cell.weight[k] * m.quantilesAt(cell.corner[k])[j];
        const auto r = modelDataRange(m);
        int zeros = 0;
        for (int j = 0; j < q; ++j) zeros += (b[j + 1] - b[j] <= 1e-12 * (r.second - r.first));
        double ws = 0;
        for (int j = 0; j < q; ++j) {
            const double wj = b[j + 1] - b[j];
            const bool zero = wj <= 1e-12 * (r.second - r.first);
            w[j] = !density ? 1.0 : (zeros ? (zero ? 1.0 : 0.0) : 1.0 / wj);
            ws += w[j];
        }
        expectMc(
            at(density ? ModelKind::QuantileMean : ModelKind::QuantileMeanMass), c.tf,
            [&] {
                double u = rng.uniform() * ws;
                int j = 0;
                while (j < q - 1 && u >= w[j]) u -= w[j++];
                return 0.5 * (b[j] + b[j + 1]);
            },
            density ? "quantile-mean" : "quantile-mean-mass");
    }
}

INSTANTIATE_TEST_SUITE_P(RandomCases, KernelMc, ::testing::Range(0, 6));

// Athawale et al. 2021 §3.2 validation of Eq. 2: q = 1000 quantiles at the corners, the
// closed-form quantile-range expectation at a 3D point against MC of the interpolated quantile
// function; and the paper's product formula Pr(Q_j) = (1/q)/w_j.
TEST(QuantileInterpolation, PaperValidationWithThousandQuantiles) {
    const int q = 1000;
    Case c = makeCase(7, q);
    const ModelVolume& m = c.model;
    CounterRng rng(5, 5, 5);
    const Rgba got = classify(m, ModelKind::QuantileRange, c.tf, c.p[0], c.p[1], c.p[2]);
    expectMc(
        got, c.tf,
        [&] {
            const double u = rng.uniform();
            double x = 0;
            for (int k = 0; k < 8; ++k)
                x += c.cell.weight[k] * voxelQuantile(m.quantilesAt(c.cell.corner[k]), q, u);
            return x;
        },
        "q=1000");
    // Product formula: corners in the paper's order; trilinear widths.
    const double al = 0.3, be = 0.6, ga = 0.8;
    for (int trial = 0; trial < 20; ++trial) {
        double w[8], pr[8];
        for (int i = 0; i < 8; ++i) {
            w[i] = 0.01 + rng.uniform();
            pr[i] = (1.0 / q) / w[i];
        }
        // The paper's t_1 = αPr_1 + (1−α)Pr_2 gives Pr_1Pr_2/t_1 = (1/q)/(α·w_2 + (1−α)·w_1):
        // α weights the second vertex's width; likewise β and γ.
        auto lerp = [](double t, double a0, double a1) { return t * a1 + (1 - t) * a0; };
        const double wInterp = lerp(ga, lerp(be, lerp(al, w[0], w[1]), lerp(al, w[2], w[3])),
                                    lerp(be, lerp(al, w[4], w[5]), lerp(al, w[6], w[7])));
        EXPECT_NEAR(paperQuantileDensity(al, be, ga, pr), (1.0 / q) / wInterp, 1e-9 / wInterp);
    }
}

TEST(Kernels, QuartileViewsAverageToQuantileRange) {
    Case c = makeCase(3, 12);
    const Rgba lo = classify(c.model, ModelKind::QuartileLower, c.tf, c.p[0], c.p[1], c.p[2]);
    const Rgba mid = classify(c.model, ModelKind::QuartileMiddle, c.tf, c.p[0], c.p[1], c.p[2]);
    const Rgba hi = classify(c.model, ModelKind::QuartileUpper, c.tf, c.p[0], c.p[1], c.p[2]);
    const Rgba all = classify(c.model, ModelKind::QuantileRange, c.tf, c.p[0], c.p[1], c.p[2]);
    EXPECT_NEAR(0.25 * lo.a + 0.5 * mid.a + 0.25 * hi.a, all.a, 1e-6);
    EXPECT_NEAR(0.25 * lo.g + 0.5 * mid.g + 0.25 * hi.g, all.g, 1e-6);
}

TEST(Kernels, DegenerateDistributionsReduceToTheMeanField) {
    // Constant samples: σ = 0, all boundaries equal, point-mass mixtures: every model = TF(x̄).
    CounterRng rng(11, 0, 0);
    ModelVolume m = testing::randomModel(rng, {2, 3, 2}, 8, 2);
    for (std::size_t v = 0; v < m.voxelCount(); ++v) {
        const float x = m.mean[v];
        m.stddev[v] = 0.f;
        m.min[v] = m.max[v] = x;
        for (int j = 0; j <= 8; ++j) m.quantiles[v * 9 + j] = x;
        m.iqr[2 * v] = m.iqr[2 * v + 1] = x;
        for (int i = 0; i < m.memberCount; ++i) m.members[v * m.memberCount + i] = x;
        for (int k = 0; k < 2; ++k) {
            m.gmm[v * 6 + 2 + k] = x;
            m.gmm[v * 6 + 4 + k] = 0.f;
        }
    }
    const auto r = modelDataRange(m);
    const TransferFunction1D tf = testing::randomTf(rng, r.first, r.second);
    ClassifyOptions minmax;
    minmax.uniformMinMax = true;
    for (float x : {0.f, 0.5f, 1.f}) {  // faces and corners included
        const float y = 2.f * x, z = 1.f - x;
        const Rgba ref = classify(m, ModelKind::Mean, tf, x, y, z);
        for (ModelKind kind : allModelKinds()) {
            if (kind == ModelKind::GmmMc) continue;
            const Rgba got = classify(m, kind, tf, x, y, z);
            EXPECT_NEAR(got.a, ref.a, 1e-5) << modelName(kind);
            EXPECT_NEAR(got.b, ref.b, 1e-5) << modelName(kind);
        }
        const Rgba got = classify(m, ModelKind::Uniform, tf, x, y, z, minmax);
        EXPECT_NEAR(got.a, ref.a, 1e-5);
    }
}

TEST(Kernels, GridFacesAndCornersUseOnlyTheNearVoxels) {
    Case c = makeCase(21, 8);
    const auto& d = c.model.grid.dims;
    const float px = static_cast<float>(d[0] - 1), py = static_cast<float>(d[1] - 1),
                pz = static_cast<float>(d[2] - 1);
    // At the far corner every model sees exactly the corner voxel's distribution.
    ModelVolume single = c.model;
    single.grid.dims = {1, 1, 1};
    const std::size_t v = c.model.grid.index(d[0] - 1, d[1] - 1, d[2] - 1);
    auto keep = [&](std::vector<float>& a, std::size_t stride) {
        a = std::vector<float>(a.begin() + static_cast<long>(v * stride),
                               a.begin() + static_cast<long>((v + 1) * stride));
    };
    keep(single.mean, 1), keep(single.stddev, 1), keep(single.min, 1), keep(single.max, 1);
    keep(single.quantiles, 9), keep(single.iqr, 2), keep(single.gmm, 9);
    keep(single.members, static_cast<std::size_t>(single.memberCount));
    for (ModelKind kind : allModelKinds()) {
        if (kind == ModelKind::GmmMc) continue;
        const Rgba a = classify(c.model, kind, c.tf, px, py, pz);
        const Rgba b = classify(single, kind, c.tf, 0.f, 0.f, 0.f);
        EXPECT_NEAR(a.a, b.a, 1e-6) << modelName(kind);
        EXPECT_NEAR(a.r, b.r, 1e-6) << modelName(kind);
        // Outside the grid clamps to the same point.
        const Rgba o = classify(c.model, kind, c.tf, px + 5, py + 1, pz + 0.5f);
        EXPECT_NEAR(o.a, a.a, 1e-6) << modelName(kind);
    }
}

TEST(Kernels, MissingArraysAndBadQuantileCountsAreUserErrors) {
    CounterRng rng(1, 2, 3);
    ModelVolume m = testing::randomModel(rng, {2, 2, 2}, 6);
    const TransferFunction1D tf = testing::randomTf(rng, -1, 1);
    auto noop = [](const auto&) {};
    EXPECT_THROW(withKernel(m, ModelKind::QuartileLower, tf, noop), UdvrError);  // 6 % 4 != 0
    EXPECT_THROW(withKernel(m, ModelKind::GmmMc, tf, noop), UdvrError);
    m.quantiles.clear();
    m.gmm.clear();
    m.iqr.clear();
    m.stddev.clear();
    for (ModelKind k : {ModelKind::QuantileRange, ModelKind::QuantileMean, ModelKind::Iqr,
                        ModelKind::GmmOrdered, ModelKind::Gaussian, ModelKind::Uniform}) {
        try {
            withKernel(m, k, tf, noop);
            ADD_FAILURE() << modelName(k);
        } catch (const UdvrError& e) {
            EXPECT_NE(std::string(e.what()).find("array"), std::string::npos) << e.what();
        }
    }
    EXPECT_NO_THROW(withKernel(m, ModelKind::Mean, tf, noop));
}

// The kind-level queries read the table's rows: only `members` reads the members, the two GMM
// models the GMM array, only gmm-mc renders realizations, and its per-sample stand-in (for
// pick) is gmm-ordered, the model with a kernel over the same array.
TEST(Kernels, KindQueriesFollowTheTableRows) {
    for (ModelKind k : allModelKinds()) {
        const std::string name(modelName(k));
        EXPECT_EQ(readsMembers(k), name == "members") << name;
        EXPECT_EQ(readsGmm(k), name == "gmm-ordered" || name == "gmm-mc") << name;
        EXPECT_EQ(rendersRealizations(k), name == "gmm-mc") << name;
        EXPECT_EQ(modelName(kernelStandIn(k)), name == "gmm-mc" ? "gmm-ordered" : name);
    }
}

TEST(Kernels, QuantileMeanZeroWidthQuantilesTakeAllTheWeight) {
    // One voxel: boundaries 0,0,1,3 (q = 3): the zero-width quantile at 0 is a point mass of
    // infinite density and gets all the weight; mass weights average TF at 0, 0.5, 2.
    ModelVolume m;
    m.grid.dims = {1, 1, 1};
    m.quantileCount = 3;
    m.quantiles = {0.f, 0.f, 1.f, 3.f};
    TransferFunction1D tf;
    tf.colorX = {0, 3};
    tf.color = {{1, 1, 1}, {1, 1, 1}};
    tf.opacityX = {0, 3};
    tf.opacity = {0.9, 0.0};
    EXPECT_NEAR(classify(m, ModelKind::QuantileMean, tf, 0, 0, 0).a, 0.9, 1e-6);
    EXPECT_NEAR(classify(m, ModelKind::QuantileMeanMass, tf, 0, 0, 0).a, (0.9 + 0.75 + 0.3) / 3,
                1e-6);
    // quantile-range: TF(0) for the zero-width quantile, then means over [0,1] and [1,3].
    EXPECT_NEAR(classify(m, ModelKind::QuantileRange, tf, 0, 0, 0).a, (0.9 + 0.75 + 0.3) / 3, 1e-6);
}

TEST(Kernels, VoxelSupportHoldsTheMass) {
    Case c = makeCase(4, 8);
    for (ModelKind kind : allModelKinds()) {
        if (kind == ModelKind::GmmMc) continue;
        withKernel(c.model, kind, c.tf, [&](const auto& k) {
            for (std::size_t v = 0; v < c.model.voxelCount(); ++v) {
                float lo, hi;
                k.voxelSupport(v, lo, hi);
                EXPECT_LE(lo, hi) << modelName(kind);
                const bool full = kind == ModelKind::Mean || kind == ModelKind::Uniform ||
                                  kind == ModelKind::Gaussian || kind == ModelKind::QuantileRange ||
                                  kind == ModelKind::QuantileMean;
                if (full) {
                    EXPECT_LE(lo, c.model.mean[v] + 1e-4f) << modelName(kind);
                    EXPECT_GE(hi, c.model.mean[v] - 1e-4f) << modelName(kind);
                }
            }
        });
    }
}

// ---- the lane and float bodies against the double body --------------------------------------

// The tangle TF (kinks only; pieces ≥ 0.5 wide, slopes ≤ 0.9 per data unit) or, with `step`,
// its opacity replaced by ramps with a step at 0.1 (pieces ≥ 0.1 wide); `dense`: the same
// function with 30 more (collinear) breakpoints, > 31 in all, so the columns are 64 long and
// lane lookups are gathers instead of 32-entry permutes. Moved by `offset` along x.
TransferFunction1D laneTestTf(bool step, bool dense, double offset) {
    TransferFunction1D tf = tangleTransferFunction();
    if (step) {
        tf.opacityX = {-3.0, -1.0, 0.1, 0.1, 2.0, 5.0};
        tf.opacity = {0.2, 0.7, 0.1, 0.9, 0.4, 0.0};
    }
    if (dense) {  // α = 0 from 5 on in both: points every ~0.98 up to 35.24 change nothing
        while (tf.opacityX.back() >= 5.0) {
            tf.opacityX.pop_back();
            tf.opacity.pop_back();
        }
        tf.opacityX.push_back(5.0);
        tf.opacity.push_back(0.0);
        for (int i = 1; i <= 30; ++i) {
            tf.opacityX.push_back(5.0 + i * (30.24 / 31.0));
            tf.opacity.push_back(0.0);
        }
        tf.opacityX.push_back(35.24);
        tf.opacity.push_back(0.0);
    }
    for (double& x : tf.colorX) x += offset;
    for (double& x : tf.opacityX) x += offset;
    return testing::withFloatBreaks(tf);
}

// The model with every value (means, bounds, quantiles, GMM means, members) moved by `offset`.
void shiftModel(ModelVolume& m, float offset) {
    for (auto* a : {&m.mean, &m.min, &m.max, &m.quantiles, &m.iqr, &m.members})
        for (float& v : *a) v += offset;
    const int k = m.gmmComponents;
    for (std::size_t v = 0; v < m.voxelCount(); ++v)
        for (int i = 0; i < k; ++i) m.gmm[v * 3 * k + k + i] += offset;
}

// Every kernel's lane body (load<Vf>/finish on kWidth cells) and float body (classifyAt<float>)
// against its double body (classifyAt<double>) at the same points. The quantile models take a
// transposed-row path while a population's boundaries fill a vector or two of kWidth, and
// per-boundary gathers beyond: q = 2, 3, 7, 8, 15, 16, 31, 32, 40 fill 4, 8, 16 or 32 lanes
// exactly or spill one boundary past them, at every width. Also GMM K = 1 and 4, the TF's
// lookups by permutes (≤ 13 breakpoints) and by gathers (≥ 43), a grid with a 1-point x axis, and
// values near 0 and near 1000. Tolerance: float boundaries, weights and Φ against double; for
// |b| ≤ 10 a few float roundings (6e−8·|b|) times the TF's slope (≤ 0.9) and the Gaussian
// bodies' ~6e−8·(σ/w)² (σ ≤ 8w): 2e−5; for |b| ~ 1000 the roundings are 100× larger: 3e−4.
// Measured worst (AVX-512): 2.3e−6 and 5.6e−5.
// Lane gathers index floats with int32: arrays of several floats per voxel past 2³¹ floats must
// take the double body (reviewer's finding: a 512³ GMM with K = 6 reaches 2.4e9).
TEST(Kernels, LaneGathersKnowWhereInt32IndicesEnd) {
    TransferFunction1D tf;
    tf.colorX = {0.0, 1.0};
    tf.color = {{1, 1, 1}, {1, 1, 1}};
    tf.opacityX = {0.0, 1.0};
    tf.opacity = {0.0, 1.0};
    const TfPiecesStorage pieces(tf);
    Grid3 big;
    big.dims = {512, 512, 512};  // 1.34e8 voxels: int32 voxel indices, not ×18 floats
    const GmmOrderedKernel gmm(big, nullptr, 6, pieces);
    EXPECT_TRUE(gmm.geometry.fitsInt32);
    EXPECT_TRUE(gmm.gathersFit(1));
    EXPECT_TRUE(gmm.gathersFit(15));   // 2.01e9 < 2³¹
    EXPECT_FALSE(gmm.gathersFit(16));  // 2.15e9
    EXPECT_FALSE(gmm.gathersFit(18));
    Grid3 huge;
    huge.dims = {1300, 1300, 1300};  // 2.2e9 voxels: no int32 voxel index at all
    EXPECT_FALSE(GmmOrderedKernel(huge, nullptr, 1, pieces).gathersFit(1));
}

// TfPieces::window and detail::withPieceWindow (the 8-piece windows of AVX2 lookups): Eq. 4
// and Eq. 5 on lanes whose boundaries span 0 … 11 pieces from random first pieces, through the
// window where it is taken, through a forced window on every target, and against the double
// body. On AVX2 both the window and the whole-TF fallback must occur.
TEST(Kernels, PieceWindowsMatchTheWholeTf) {
    using lanes::Vf;
    CounterRng rng(91, 0, 0);
    int windows = 0, fallbacks = 0, forced = 0;
    for (int breaks : {9, 20}) {  // 16- and 32-entry lookups on AVX2
        TransferFunction1D tf;
        for (int i = 0; i < breaks; ++i) {
            tf.colorX.push_back(i);
            tf.color.push_back({rng.uniform(), rng.uniform(), rng.uniform()});
            tf.opacityX.push_back(i);
            tf.opacity.push_back(rng.uniform());
        }
        const TfPiecesStorage st(tf);
        const auto& whole = st.fast().sized<kTfSmall>();
        const QuantileLevels levels;
        constexpr int q = 8;
        for (int trial = 0; trial < 400; ++trial) {
            // Lane l's boundaries: sorted uniforms over [x0, x0 + span] (span up to 12 pieces).
            const double x0 = -1.0 + (breaks + 1.0) * rng.uniform();
            const double span = 12.0 * rng.uniform();
            Vf b[q + 1], w[q];
            for (int l = 0; l < lanes::kWidth; ++l) {
                double v[q + 1];
                for (double& x : v) x = x0 + span * rng.uniform() * (0.5 + 0.5 * rng.uniform());
                std::sort(v, v + q + 1);
                for (int j = 0; j <= q; ++j) b[j][l] = static_cast<float>(v[j]);
            }
            for (int j = 0; j < q; ++j) w[j] = b[j + 1] - b[j];
            const lanes::Mask live =
                trial % 3 == 0 ? lanes::allTrue<Vf>()
                               : lanes::fromBits(static_cast<std::uint32_t>(rng.nextBits() | 1u));
            const auto boundary = [&](int j) { return b[j]; };
            const auto width = [&](int j) { return w[j]; };
            const auto classify = [&](const auto& view, Vf range[4], Vf mean[4]) {
                expectedTfQuantileRange<Vf>(view, boundary, q + 1, levels, range);
                expectedTfQuantileMean<Vf>(view, boundary, width, q, levels, true,
                                           lanes::splat<Vf>(1e-12f), live, mean);
            };
            Vf range[4], mean[4];
            detail::withPieceWindow(whole, b[0], b[q], live, true, [&](const auto& view) {
                (std::decay_t<decltype(view)>::kLookupSize == 8 ? windows : fallbacks) += 1;
                classify(view, range, mean);
            });
            // The window itself on every target (AVX-512's 8-entry lookup reads 16 entries).
            const int first = whole.pieceOf(lanes::minOf(b[0], live));
            const int last = whole.pieceOf(lanes::maxOf(b[q], live));
            Vf rangeW[4], meanW[4];
            const bool fits = last - first < 8 && first + 16 <= whole.stride;
            if (fits) {
                ++forced;
                classify(whole.window(first, last - first), rangeW, meanW);
            }
            for (int l = 0; l < lanes::kWidth; ++l) {
                if (!live[l]) continue;
                double bl[q + 1];
                for (int j = 0; j <= q; ++j) bl[j] = b[j][l];
                double wantRange[4], wantMean[4];
                expectedTfQuantileRange<double>(
                    st.exact(), [&](int j) { return bl[j]; }, q + 1, levels, wantRange);
                expectedTfQuantileMean<double>(
                    st.exact(), [&](int j) { return bl[j]; },
                    [&](int j) { return static_cast<double>(w[j][l]); }, q, levels, true, 1e-12,
                    true, wantMean);
                for (int ch = 0; ch < 4; ++ch) {
                    EXPECT_NEAR(range[ch][l], wantRange[ch], 2e-5) << breaks << " " << trial;
                    EXPECT_NEAR(mean[ch][l], wantMean[ch], 2e-5) << breaks << " " << trial;
                    if (!fits) continue;
                    EXPECT_NEAR(rangeW[ch][l], wantRange[ch], 2e-5) << breaks << " " << trial;
                    EXPECT_NEAR(meanW[ch][l], wantMean[ch], 2e-5) << breaks << " " << trial;
                }
            }
        }
    }
    EXPECT_GT(forced, 200);
    if (lanes::kWindowLookups) {
        EXPECT_GT(windows, 200);
        EXPECT_GT(fallbacks, 50);
    } else {
        EXPECT_EQ(windows, 0);
    }
}

TEST(Kernels, LaneAndFloatBodiesMatchTheDoubleBody) {
    CounterRng rng(77, 0, 0);
    for (const std::array<int, 3>& dims :
         {std::array<int, 3>{5, 4, 3}, std::array<int, 3>{1, 4, 3}})
        for (int gmmK : {1, 4})
            for (int q : {2, 3, 7, 8, 15, 16, 31, 32, 40}) {
                ModelVolume base = testing::randomModel(rng, dims, q, gmmK);
                for (float offset : {0.f, 1000.f}) {
                    ModelVolume m = base;
                    shiftModel(m, offset);
                    const double tol = offset > 0.f ? 3e-4 : 2e-5;
                    for (bool dense : {false, true}) {
                        // A step moves by a boundary's float rounding (×100 at 1000) into or
                        // out of a quantile, by (jump / quantile width) × that: steps only near 0.
                        const TransferFunction1D tf = laneTestTf(offset == 0.f, dense, offset);
                        for (ModelKind listed : allModelKinds()) {
                            // uniform-exact's lanes run its double body; uniform-fast is
                            // uniform and gaussian-exact the 1D gaussian.
                            if (listed == ModelKind::GmmMc || listed == ModelKind::UniformFast ||
                                listed == ModelKind::UniformExact ||
                                listed == ModelKind::GaussianExact)
                                continue;
                            const ModelKind kind = listed;
                            const bool quantile = needsQuantiles(kind);
                            const bool quartile = kind == ModelKind::QuartileLower ||
                                                  kind == ModelKind::QuartileMiddle ||
                                                  kind == ModelKind::QuartileUpper;
                            if (quartile && q % 4 != 0) continue;
                            if (!quantile && q != 8) continue;  // q matters to quantile models
                            if (kind != ModelKind::GmmOrdered && gmmK != 4) continue;  // K: GMM
                            for (bool minMax : {false, true}) {
                                if (minMax && listed != ModelKind::Uniform) continue;
                                ClassifyOptions o;
                                o.uniformMinMax = minMax;
                                const std::string what = std::string(modelName(kind)) +
                                                         " q=" + std::to_string(q) +
                                                         " K=" + std::to_string(gmmK) +
                                                         " dense=" + std::to_string(dense) +
                                                         " offset=" + std::to_string(offset) +
                                                         " dims.x=" + std::to_string(dims[0]);
                                withKernel(m, kind, tf, o, [&](const auto& k) {
                                    const double worst =
                                        testing::worstLaneError(k, rng, dims, what);
                                    EXPECT_LE(worst, tol) << what;
                                });
                            }
                        }
                    }
                }
            }
}

}  // namespace
}  // namespace udvr
