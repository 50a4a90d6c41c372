// The `members` kernel (issue 12: the ensemble's own expected classification) against a brute
// force written here from its definition: at a point, each member interpolated trilinearly from
// its own grid values, the TF applied to each, averaged over the members. Double, float-thread
// and lane bodies; one member and identical members against the mean-field kernel.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "udvr/classify/classify_test_util.h"
#include "udvr/classify/kernel_test_util.h"
#include "udvr/classify/model_families.h"

namespace udvr {
namespace {

using lanes::Vf;

// A member-major ensemble of n smooth-ish random members over `dims`: a shared random field
// plus per-member noise of a random scale, so members differ by little or much.
Ensemble randomEnsemble(CounterRng& rng, const std::array<int, 3>& dims, int n) {
    Ensemble e;
    e.grid.dims = dims;
    e.members = n;
    const std::size_t voxels = e.grid.pointCount();
    std::vector<double> base(voxels);
    for (double& b : base) b = 2.0 * rng.normal();
    for (int i = 0; i < n; ++i) {
        const double scale = 0.1 + 1.5 * rng.uniform();
        for (std::size_t v = 0; v < voxels; ++v)
            e.values.push_back(static_cast<float>(base[v] + scale * rng.normal()));
    }
    return e;
}

// (1/n) Σ_i TF(f_i(p)), f_i(p) = Σ_c w_c f_{i,c}: the corners and weights of SPEC §1/§3 written
// out in the tests (testing::refCell, not reconstruct/cell.h), the TF from its control points
// (colorAt, opacityAt, not the kernels' pieces), all in double, from the member-major ensemble
// (not the kernel's voxel-major copy).
std::array<double, 4> bruteForce(const Ensemble& e, const TransferFunction1D& tf, float x, float y,
                                 float z) {
    const testing::RefCell cell = testing::refCell(e.grid.dims, x, y, z);
    std::array<double, 4> sum{};
    for (int i = 0; i < e.members; ++i) {
        double value = 0.0;
        for (int k = 0; k < 8; ++k) value += cell.weight[k] * e.member(i)[cell.corner[k]];
        const double a = tf.opacityAt(value);
        const auto c = tf.colorAt(value);
        for (int ch = 0; ch < 3; ++ch) sum[ch] += a * c[ch];
        sum[3] += a;
    }
    for (double& s : sum) s /= e.members;
    return sum;
}

// A random TF over [lo, hi] without steps (a step turns a member's float rounding into a jump).
TransferFunction1D smoothTf(CounterRng& rng, double lo, double hi) {
    TransferFunction1D tf = testing::randomTf(rng, lo, hi);
    for (auto* xs : {&tf.colorX, &tf.opacityX})
        for (std::size_t i = 1; i < xs->size(); ++i)
            (*xs)[i] = std::max((*xs)[i], (*xs)[i - 1] + 0.05 * (hi - lo));
    return testing::withFloatBreaks(tf);
}

template <class F>
void withMembers(const ModelVolume& m, const TransferFunction1D& tf, F&& f) {
    withKernel(m, ModelKind::Members, tf, [&](const auto& k) {
        if constexpr (std::is_same_v<std::decay_t<decltype(k)>, MembersKernel>)
            f(k);
        else
            ADD_FAILURE() << "members did not make a MembersKernel";
    });
}

// Member counts around the batch's row blocks at every width (4, 8, 16 lanes: blocks of 8, 16,
// 32 members) and a 50-member ensemble.
constexpr int kCounts[] = {1, 2, 3, 7, 8, 9, 15, 16, 17, 31, 32, 33, 50};

TEST(MembersKernel, EqualsTheBruteForceAverageOverMembers) {
    CounterRng rng(1201, 0, 0);
    for (const std::array<int, 3>& dims :
         {std::array<int, 3>{5, 4, 3}, std::array<int, 3>{1, 4, 3}})
        for (int n : kCounts) {
            const Ensemble e = randomEnsemble(rng, dims, n);
            const ModelVolume m = membersModel(e);
            ASSERT_EQ(m.memberCount, n);
            const auto [lo, hi] = std::minmax_element(e.values.begin(), e.values.end());
            // The TF covers part of the values (clamping) or all of them.
            const double span = *hi - *lo;
            const TransferFunction1D tf =
                smoothTf(rng, *lo + (n % 2 ? 0.3 : -0.1) * span, *hi + 0.1 * span);
            const std::string what =
                "n=" + std::to_string(n) + " dims.x=" + std::to_string(dims[0]);
            withMembers(m, tf, [&](const MembersKernel& k) {
                double worstDouble = 0.0, worstFast = 0.0;
                for (int trial = 0; trial < 40; ++trial) {
                    Vf p[3];
                    testing::randomPoints(rng, dims, p);
                    const lanes::Mask live =
                        trial == 0 ? lanes::allTrue<Vf>()
                                   : lanes::fromBits(static_cast<std::uint32_t>(
                                         rng.nextBits() & ((1u << lanes::kWidth) - 1u)));
                    Vf batch[4];
                    k.finish(k.load<Vf>(cellAt<Vf>(k.geometry, p[0], p[1], p[2]), live), batch);
                    for (int l = 0; l < lanes::kWidth; ++l) {
                        if (!live[l]) {
                            for (int ch = 0; ch < 4; ++ch) EXPECT_EQ(batch[ch][l], 0.f) << what;
                            continue;
                        }
                        const auto want = bruteForce(e, tf, p[0][l], p[1][l], p[2][l]);
                        double exact[4];
                        float one[4];
                        classifyAt<double>(k, p[0][l], p[1][l], p[2][l], exact);
                        classifyAt<float>(k, p[0][l], p[1][l], p[2][l], one);
                        for (int ch = 0; ch < 4; ++ch) {
                            worstDouble = std::max(worstDouble, std::abs(exact[ch] - want[ch]));
                            worstFast = std::max({worstFast, std::abs(batch[ch][l] - want[ch]),
                                                  std::abs(one[ch] - want[ch])});
                        }
                    }
                }
                EXPECT_LE(worstDouble, 1e-12) << what;
                // Float members, weights and TF pieces: a few roundings of values |f| ≲ 10.
                EXPECT_LE(worstFast, 1e-5) << what;
            });
        }
}

// The mean-field kernel over `field` and the members kernel over the ensemble `e`, at random
// points: max |members − mean| per body (double, float thread, lanes with every lane live).
std::array<double, 3> worstAgainstMean(const Ensemble& e, const std::vector<float>& field,
                                       const TransferFunction1D& tf, CounterRng& rng) {
    std::array<double, 3> worst{};
    const ModelVolume m = membersModel(e);
    const TfPiecesStorage pieces(tf);
    const MeanKernel mean(e.grid, field.data(), pieces);
    withMembers(m, tf, [&](const MembersKernel& k) {
        for (int trial = 0; trial < 40; ++trial) {
            Vf p[3];
            testing::randomPoints(rng, e.grid.dims, p);
            Vf a[4], b[4];
            const lanes::Mask all = lanes::allTrue<Vf>();
            k.finish(k.load<Vf>(cellAt<Vf>(k.geometry, p[0], p[1], p[2]), all), a);
            mean.finish(mean.load<Vf>(cellAt<Vf>(mean.geometry, p[0], p[1], p[2]), all), b);
            for (int l = 0; l < lanes::kWidth; ++l) {
                double x[4], y[4];
                float u[4], v[4];
                classifyAt<double>(k, p[0][l], p[1][l], p[2][l], x);
                classifyAt<double>(mean, p[0][l], p[1][l], p[2][l], y);
                classifyAt<float>(k, p[0][l], p[1][l], p[2][l], u);
                classifyAt<float>(mean, p[0][l], p[1][l], p[2][l], v);
                for (int ch = 0; ch < 4; ++ch) {
                    worst[0] = std::max(worst[0], std::abs(x[ch] - y[ch]));
                    worst[1] = std::max(worst[1], static_cast<double>(std::abs(u[ch] - v[ch])));
                    worst[2] =
                        std::max(worst[2], static_cast<double>(std::abs(a[ch][l] - b[ch][l])));
                }
            }
        }
    });
    return worst;
}

TEST(MembersKernel, OneMemberIsTheMeanFieldExactly) {
    CounterRng rng(1202, 0, 0);
    for (const std::array<int, 3>& dims :
         {std::array<int, 3>{6, 5, 4}, std::array<int, 3>{1, 3, 2}}) {
        const Ensemble e = randomEnsemble(rng, dims, 1);
        const TransferFunction1D tf = testing::randomTf(rng, -4.0, 4.0);  // steps too
        // The same lerps and the same TF lookup: bit for bit on lanes (explicit FMAs); the
        // scalar bodies' a·b + c is contracted as the compiler inlines it: within an ulp.
        const auto worst = worstAgainstMean(e, e.values, tf, rng);
        EXPECT_LE(worst[0], 1e-15);
        EXPECT_LE(worst[1], 1.2e-7);
        EXPECT_EQ(worst[2], 0.0);
    }
}

TEST(MembersKernel, IdenticalMembersAreTheMeanField) {
    CounterRng rng(1203, 0, 0);
    for (int n : {2, 5, 33}) {
        const Ensemble one = randomEnsemble(rng, {5, 4, 3}, 1);
        Ensemble e = one;
        e.members = n;
        for (int i = 1; i < n; ++i)
            e.values.insert(e.values.end(), one.values.begin(), one.values.end());
        const TransferFunction1D tf = testing::randomTf(rng, -4.0, 4.0);
        // n equal terms summed and scaled by 1/n: a few roundings of values ≤ 1.
        const auto worst = worstAgainstMean(e, one.values, tf, rng);
        EXPECT_LE(worst[0], 1e-15) << n;
        EXPECT_LE(worst[1], 1e-6) << n;
        EXPECT_LE(worst[2], 1e-6) << n;
    }
}

TEST(MembersKernel, SupportIsTheMembersRangeAndSkippingKeepsTheImage) {
    CounterRng rng(1204, 0, 0);
    const Ensemble e = randomEnsemble(rng, {4, 3, 3}, 6);
    const ModelVolume m = membersModel(e);
    withMembers(m, testing::randomTf(rng, -3.0, 3.0), [&](const MembersKernel& k) {
        for (std::size_t v = 0; v < m.voxelCount(); ++v) {
            float lo, hi;
            k.voxelSupport(v, lo, hi);
            float wantLo = e.member(0)[v], wantHi = wantLo;
            for (int i = 1; i < e.members; ++i) {
                wantLo = std::min(wantLo, e.member(i)[v]);
                wantHi = std::max(wantHi, e.member(i)[v]);
            }
            EXPECT_EQ(lo, wantLo);
            EXPECT_EQ(hi, wantHi);
            // The voxel-major copy and the mean of its members.
            double sum = 0.0;
            for (int i = 0; i < e.members; ++i) {
                EXPECT_EQ(m.members[v * 6 + static_cast<std::size_t>(i)], e.member(i)[v]);
                sum += e.member(i)[v];
            }
            EXPECT_NEAR(m.mean[v], sum / 6, 1e-6);
        }
    });
}

TEST(MembersKernel, ModelsAndFieldsWithoutMembersAreRefused) {
    CounterRng rng(1205, 0, 0);
    const TransferFunction1D tf = testing::randomTf(rng, -3.0, 3.0);
    ScalarField f;
    f.grid.dims = {2, 2, 2};
    f.values.assign(8, 1.f);
    ModelVolume model = testing::randomModel(rng, {2, 2, 2}, 4);
    model.members.clear();
    model.memberCount = 0;
    for (const ModelVolume& m : {modelFromField(f), model}) {
        try {
            withKernel(m, ModelKind::Members, tf, [](const auto&) {});
            ADD_FAILURE() << "members without an ensemble";
        } catch (const UdvrError& err) {
            EXPECT_NE(std::string(err.what()).find("needs an ensemble"), std::string::npos)
                << err.what();
        }
    }
}

}  // namespace
}  // namespace udvr
