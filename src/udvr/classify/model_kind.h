#pragma once
// The noise models of SPEC §3–4, by CLI name: the enumerators and the data of the model table's
// rows (model_rows.h, the one list of models).
#include <array>
#include <cstddef>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "udvr/classify/model_rows.h"

namespace udvr {

/// One per row of model_rows.h, in row order (`ModelKind::Mean`, …).
enum class ModelKind {
#define UDVR_MODEL_ENUMERATOR(Enumerator, ...) Enumerator,
    UDVR_MODEL_ROWS(UDVR_MODEL_ENUMERATOR)
#undef UDVR_MODEL_ENUMERATOR
};

/// The per-voxel arrays of SPEC §7.
enum ModelArray : unsigned {
    kArrayMean = 1u << 0,
    kArrayStddev = 1u << 1,
    kArrayMin = 1u << 2,
    kArrayMax = 1u << 3,
    kArrayQuantiles = 1u << 4,  // q + 1 per voxel
    kArrayIqr = 1u << 5,        // 2 per voxel
    kArrayGmm = 1u << 6,        // 3K per voxel
    kArrayMembers = 1u << 7,    // n per voxel: the ensemble itself (membersModel), not a file's
};

/// Eq. 5's weights p_j of the quantile-mean family (None: another model).
enum class QuantileMeanWeights : unsigned char { None, Density, Equal };

/// A row of the model table without its kernels (model_rows.h gives the values; ModelFamily,
/// model_families.h, adds the kernel factories).
struct ModelRow {
    ModelKind kind;
    std::string_view name;  // the CLI name (SPEC §3–4)
    std::string_view help;  // what `--model NAME` renders, for the CLI's help
    /// Arrays the classification reads (ModelArray bits), and with `--uniform-width minmax`
    /// where that differs (0: the same).
    unsigned arrays = 0;
    unsigned minMaxArrays = 0;
    /// For the quantile-range family: the covered rank interval [lo, hi] of [0, 1] (SPEC §4
    /// quartile views); {0, 0} for other models.
    std::pair<double, double> population{0.0, 0.0};
    /// Its label names q (models that read q + 1 boundaries of the `quantiles` array).
    bool labelShowsQ = false;
    /// gmm-mc: rendered as the screen-space average of mean-field realizations; no kernel.
    bool realizations = false;
    /// The reference evaluation of a model whose default is a fast form (uniform-exact,
    /// gaussian-exact).
    bool exactForm = false;
    QuantileMeanWeights quantileMeanWeights = QuantileMeanWeights::None;
    /// A frame's cost at the reference speed, ns per pixel × ray step, with a 1D TF, a 2D TF and
    /// bivariate fields (members: per member; gmm-mc: per realization, besides drawing it):
    /// what the experiments' estimate before they start scales (eval/experiment_plan.cpp says
    /// how they were measured). 0: not measured (the plan's default for the TF kind).
    std::array<double, 3> nsPerStep{};

    /// The arrays read with `--uniform-width minmax` (minMax) or without.
    constexpr unsigned arraysFor(bool minMax) const {
        return minMax && minMaxArrays ? minMaxArrays : arrays;
    }
    /// Floats stored per voxel for the model (its arrays without minmax), relative to the mean
    /// field's one (q quantiles, k GMM components, n members).
    constexpr double floatsPerVoxel(int q, int k, int n) const {
        double f = 0.0;
        for (unsigned bit : {kArrayMean, kArrayStddev, kArrayMin, kArrayMax})
            f += (arrays & bit) ? 1.0 : 0.0;
        if (arrays & kArrayQuantiles) f += q + 1.0;
        if (arrays & kArrayIqr) f += 2.0;
        if (arrays & kArrayGmm) f += 3.0 * k;
        if (arrays & kArrayMembers) f += n;
        return f;
    }
};

/// Values that several rows of model_rows.h share, each written once.
/// The arrays of the uniform and gaussian rows (every form), and uniform's with
/// `--uniform-width minmax`.
inline constexpr unsigned kMeanAndStddev = kArrayMean | kArrayStddev;
inline constexpr unsigned kMinAndMax = kArrayMin | kArrayMax;
/// nsPerStep measured for a kernel and taken by every row that runs it on the same arrays:
/// `uniform`'s for its alias `uniform-fast`; `quantile-range`'s for the quartile views (the
/// same kernel over a part of the quantiles: an upper bound); `quantile-mean`'s for
/// `quantile-mean-mass` (the same kernel, other weights).
inline constexpr std::array<double, 3> kUniformCost{150.0, 5000.0, 1160.0};
inline constexpr std::array<double, 3> kQuantileRangeCost{18.8, 89.0, 263.0};
inline constexpr std::array<double, 3> kQuantileMeanCost{13.0, 20.0, 161.0};

/// Every row's data, in row order (kModelRows[i].kind == ModelKind(i)).
inline constexpr ModelRow kModelRows[] = {
#define UDVR_MODEL_ROW_DATA(Enumerator, Kernel1D, Kernel2D, KernelBivariate, ...) \
    ModelRow{.kind = ModelKind::Enumerator, __VA_ARGS__},
    UDVR_MODEL_ROWS(UDVR_MODEL_ROW_DATA)
#undef UDVR_MODEL_ROW_DATA
};
inline constexpr std::size_t kModelCount = std::size(kModelRows);

/// The row of a model (its data; modelFamily adds the kernels).
constexpr const ModelRow& modelRow(ModelKind kind) {
    return kModelRows[static_cast<std::size_t>(kind)];
}

/// Parse a CLI model name ("quantile-mean"); throws UdvrError listing the valid names.
ModelKind parseModelKind(std::string_view name);
/// The CLI name of a model.
std::string_view modelName(ModelKind kind);
/// All models, in the order of SPEC §3–4.
const std::vector<ModelKind>& allModelKinds();
/// The names of the models (in table order, "mean, uniform, …"); with a 2D TF (SPEC §9) only
/// those with a 2D classification.
std::string modelNames(bool twoD = false);
/// The `--model` help: every model's name with its row's help, then the models with a 2D TF
/// (`--tf2`) and with bivariate fields (`--second`).
std::string modelHelp();
/// Whether a model needs the quantile boundaries array.
bool needsQuantiles(ModelKind kind);
/// Whether a model reads the GMM array (its label names K).
bool readsGmm(ModelKind kind);
/// Whether a model reads an ensemble's members themselves, not a model file (`members`).
bool readsMembers(ModelKind kind);
/// Whether a model is rendered as the average of whole-image realizations (no per-sample kernel).
bool rendersRealizations(ModelKind kind);
/// The model whose per-sample kernel stands in for `kind` where one sample's classification is
/// needed (pick): `kind` itself, or for a model without a kernel (gmm-mc) the first model with
/// a kernel that reads the same arrays (gmm-ordered).
ModelKind kernelStandIn(ModelKind kind);

}  // namespace udvr
