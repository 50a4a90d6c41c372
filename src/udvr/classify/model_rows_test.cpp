// The model table (model_rows.h): every row complete, its kernels wired to its columns, and
// each claimed kernel reading exactly the arrays the row claims. What a new row can get wrong
// that the compiler does not see.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <set>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "udvr/classify/classify_test_util.h"
#include "udvr/classify/model_families.h"
#include "udvr/classify/transfer_function_2d.h"
#include "udvr/util/check.h"

namespace udvr {
namespace {

// Every row: its kind is its index, a unique CLI name of [a-z0-9-] that parses back to it, a
// help phrase, the arrays it reads; the fields that only some models have agree with its arrays
// (q in the label, a population, Eq. 5's weights: the quantiles array), and a model has a
// per-sample kernel exactly when it is not rendered by realizations.
TEST(ModelFamilies, EveryRowIsComplete) {
    std::set<std::string_view> names;
    ASSERT_EQ(modelFamilies().size(), kModelCount);
    for (std::size_t i = 0; i < kModelCount; ++i) {
        const ModelFamily& f = modelFamilies()[i];
        const std::string what = "row " + std::to_string(i) + " '" + std::string(f.name) + "'";
        EXPECT_EQ(static_cast<std::size_t>(f.kind), i) << what;
        EXPECT_EQ(&modelFamily(f.kind), &f) << what;
        EXPECT_FALSE(f.name.empty()) << what;
        EXPECT_TRUE(std::all_of(f.name.begin(), f.name.end(), [](char c) {
            return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-';
        })) << what;
        EXPECT_TRUE(names.insert(f.name).second) << what << ": name used twice";
        EXPECT_EQ(parseModelKind(f.name), f.kind) << what;
        EXPECT_GE(f.help.size(), 5u) << what << ": no help phrase";
        EXPECT_EQ(f.help.find('|'), std::string_view::npos) << what << ": '|' separates models";
        EXPECT_NE(modelHelp().find(std::string(f.name) + ": " + std::string(f.help)),
                  std::string::npos)
            << what;
        EXPECT_NE(f.arrays, 0u) << what << ": reads no array";
        if (f.minMaxArrays) {
            EXPECT_NE(f.minMaxArrays, f.arrays) << what;
        }
        const bool quantiles = (f.arrays & kArrayQuantiles) != 0;
        if (f.labelShowsQ) {
            EXPECT_TRUE(quantiles) << what;
        }
        if (f.population.second > f.population.first) {
            EXPECT_TRUE(quantiles) << what;
            EXPECT_GE(f.population.first, 0.0) << what;
            EXPECT_LE(f.population.second, 1.0) << what;
        } else {
            EXPECT_EQ(f.population, (std::pair<double, double>{0.0, 0.0})) << what;
        }
        if (f.quantileMeanWeights != QuantileMeanWeights::None) {
            EXPECT_TRUE(quantiles) << what;
        }
        EXPECT_EQ(f.makeKernel == nullptr, f.realizations) << what;
        if (!f.makeKernel) {
            EXPECT_EQ(f.makeKernel2D, nullptr) << what;
            EXPECT_EQ(f.makeBivariate, nullptr) << what;
        }
    }
}

// modelArrayNames (what udvr.models() gives Python): one name per bit, in bit order, every bit
// of every row's arrays named.
TEST(ModelFamilies, ArrayNamesNameEveryBitOnce) {
    EXPECT_EQ(modelArrayNames(kArrayGmm | kArrayMean),
              (std::vector<std::string_view>{"mean", "gmm"}));
    EXPECT_EQ(modelArrayNames(kArrayMembers), (std::vector<std::string_view>{"members"}));
    EXPECT_TRUE(modelArrayNames(0).empty());
    for (const ModelFamily& f : modelFamilies())
        for (unsigned arrays : {f.arrays, f.arraysFor(true)})
            EXPECT_EQ(modelArrayNames(arrays).size(),
                      static_cast<std::size_t>(std::popcount(arrays)))
                << f.name;
}

// A kernel column K: the row's factory `make` builds a K (build() calls it); NoKernel: there is
// no factory.
template <class K, class Make, class Build>
void expectColumn(Make make, const Build& build, const std::string& what) {
    if constexpr (std::is_same_v<K, NoKernel>) {
        EXPECT_EQ(make, nullptr) << what;
    } else {
        ASSERT_NE(make, nullptr) << what;
        EXPECT_TRUE(std::holds_alternative<K>(build())) << what;
    }
}

// The kernel types a row names are the ones its factories build.
TEST(ModelFamilies, FactoriesBuildTheRowsKernelTypes) {
    CounterRng rng(5, 1, 7);
    const ModelVolume volume = testing::randomModel(rng, {3, 3, 2}, 8);
    const ModelView m(volume);
    const TransferFunction1D tf = testing::randomTf(rng, -3.0, 3.0);
    const TfPiecesStorage pieces(tf);
    const TransferFunction2D tf2 = transferFunction2DFrom1D(tf, 21, -5.0, 5.0);
    GradientCache cache;
    Tf2Setup setup(tf2, m, cache);
    const TfPiecesStorage none(reconstructionOnlyTf());
    const ClassifyOptions o;
#define UDVR_CHECK_ROW(Enumerator, Kernel1D, Kernel2D, KernelBivariate, ...)                   \
    {                                                                                          \
        const ModelFamily& f = modelFamily(ModelKind::Enumerator);                             \
        const std::string what(f.name);                                                        \
        expectColumn<Kernel1D>(                                                                \
            f.makeKernel, [&] { return f.makeKernel(m, pieces, o, f); }, what + " 1D");        \
        expectColumn<Kernel2D>(                                                                \
            f.makeKernel2D, [&] { return f.makeKernel2D(m, setup, o, f); }, what + " 2D");     \
        expectColumn<KernelBivariate>(                                                         \
            f.makeBivariate, [&] { return f.makeBivariate(m, m, setup.rasters, none, o, f); }, \
            what + " bivariate");                                                              \
    }
    UDVR_MODEL_ROWS(UDVR_CHECK_ROW)
#undef UDVR_CHECK_ROW
}

// Each model over only the arrays its row claims (the others emptied; `mean` kept for a TF2,
// which needs n̂): every TF kind it claims classifies, and with a y-constant TF2 (the 1D TF as a
// raster, clamped beyond its domain) its 2D and bivariate classifications equal its 1D one —
// a row wired to another model's arrays, population or weights would not. Without any one
// claimed array each kind is a user error; a TF kind the row does not claim is one too. The 2D
// and bivariate forms of the fast models (uniform, gaussian) are within 1e−3 of the exact
// expectation, their 1D form within 4e−4: 2e−3 between them; the exact forms agree to float
// rounding of the raster.
TEST(ModelFamilies, ClaimedKernelsReadExactlyTheirArrays) {
    CounterRng rng(31, 4, 1);
    const std::array<int, 3> dims{4, 4, 3};
    const ModelVolume full = testing::randomModel(rng, dims, 8);
    TransferFunction1D tf = testing::randomTf(rng, -5.0, 5.0);
    // Breakpoints on the raster's columns (x step 0.25), at least a column apart.
    for (auto* xs : {&tf.colorX, &tf.opacityX}) {
        for (double& x : *xs) x = 0.25 * std::round(4 * x);
        for (std::size_t i = 1; i < xs->size(); ++i)
            (*xs)[i] = std::max((*xs)[i], (*xs)[i - 1] + 0.25);
    }
    const TransferFunction2D tf2 = transferFunction2DFrom1D(tf, 81, -10.0, 10.0, -1.0, 2.0);
    const ClassifyOptions options;
    const auto strip = [&](unsigned keep) {
        ModelVolume m = full;
        if (!(keep & kArrayMean)) m.mean.clear();
        if (!(keep & kArrayStddev)) m.stddev.clear();
        if (!(keep & kArrayMin)) m.min.clear();
        if (!(keep & kArrayMax)) m.max.clear();
        if (!(keep & kArrayQuantiles)) m.quantiles.clear();
        if (!(keep & kArrayIqr)) m.iqr.clear();
        if (!(keep & kArrayGmm)) m.gmm.clear();
        if (!(keep & kArrayMembers)) m.members.clear();
        return m;
    };
    int claimed2D = 0, claimedBivariate = 0;
    for (const ModelFamily& f : modelFamilies()) {
        const std::string what(f.name);
        const ModelVolume own = strip(f.arrays);
        const ModelVolume ownWithMean = strip(f.arrays | kArrayMean);
        for (unsigned bit = 1; bit <= kArrayMembers; bit <<= 1) {
            if (!(f.arrays & bit)) continue;
            const ModelVolume lacking = strip(f.arrays & ~bit);
            EXPECT_THROW(checkModelHasArrays(lacking, f.kind, options), UdvrError)
                << what << " without array bit " << bit;
        }
        if (!f.makeKernel) continue;
        const auto noop = [](const auto&) {};
        for (int trial = 0; trial < 12; ++trial) {
            const float p[3] = {static_cast<float>(rng.uniform() * (dims[0] - 1)),
                                static_cast<float>(rng.uniform() * (dims[1] - 1)),
                                static_cast<float>(rng.uniform() * (dims[2] - 1))};
            double one[4];
            withKernel(own, f.kind, tf, options,
                       [&](const auto& k) { classifyAt<double>(k, p[0], p[1], p[2], one); });
            for (int ch = 0; ch < 4; ++ch) {
                EXPECT_TRUE(std::isfinite(one[ch])) << what;
                EXPECT_GE(one[ch], -1e-12) << what;
                EXPECT_LE(one[ch], 1.0 + 1e-9) << what;
            }
            const double tol = f.exactForm || (f.name != "uniform" && f.name != "uniform-fast" &&
                                               f.name != "gaussian")
                                   ? 2e-6
                                   : 2e-3;
            if (f.makeKernel2D) {
                double two[4];
                withKernel2D(ownWithMean, f.kind, tf2, options,
                             [&](const auto& k) { classifyAt<double>(k, p[0], p[1], p[2], two); });
                for (int ch = 0; ch < 4; ++ch)
                    EXPECT_NEAR(two[ch], one[ch], tol) << what << " 2D ch " << ch;
            } else {
                EXPECT_THROW(withKernel2D(ownWithMean, f.kind, tf2, options, noop), UdvrError)
                    << what;
            }
            if (f.makeBivariate) {
                double two[4];
                // y from a second field of the same model: the TF2 ignores it.
                withKernelBivariate(own, own, f.kind, tf2, options, [&](const auto& k) {
                    classifyAt<double>(k, p[0], p[1], p[2], two);
                });
                for (int ch = 0; ch < 4; ++ch)
                    EXPECT_NEAR(two[ch], one[ch], tol) << what << " bivariate ch " << ch;
            } else {
                EXPECT_THROW(withKernelBivariate(own, own, f.kind, tf2, options, noop), UdvrError)
                    << what;
            }
        }
        claimed2D += f.makeKernel2D != nullptr;
        claimedBivariate += f.makeBivariate != nullptr;
    }
    EXPECT_GT(claimed2D, 0);
    EXPECT_GT(claimedBivariate, claimed2D);
}

}  // namespace
}  // namespace udvr
