#pragma once
// The noise models of SPEC §3–4, by CLI name.
#include <string>
#include <string_view>
#include <vector>

namespace udvr {

enum class ModelKind {
    Mean,              // mean field
    Uniform,           // box spline of 8 scaled uniforms, in its fast form (within 4e−4 in 1D)
    Gaussian,          // N(Σwμ, Σw²σ²)
    GmmOrdered,        // rank-wise interpolated mixture
    GmmMc,             // Monte Carlo realizations, averaged in screen space (render only)
    QuantileRange,     // Athawale et al. 2021, Eq. 4
    QuantileMean,      // Eq. 5, density weights
    QuantileMeanMass,  // Eq. 5 with equal weights 1/q
    Iqr,               // middle 50 %
    QuartileLower,     // quantile-range over [0, .25]
    QuartileMiddle,    // quantile-range over [.25, .75]
    QuartileUpper,     // quantile-range over [.75, 1]
    Members,           // no model: the TF averaged over an ensemble's members (issue 12)
    UniformFast,       // an alias of `uniform` (the fast form; its name before issue 33)
    UniformExact,      // the uniform model's box spline, exactly (the reference for `uniform`)
    GaussianExact,     // gaussian; with a 2D TF the exact evaluation (the reference for `gaussian`)
};

/// Parse a CLI model name ("quantile-mean"); throws UdvrError listing the valid names.
ModelKind parseModelKind(std::string_view name);
/// The CLI name of a model.
std::string_view modelName(ModelKind kind);
/// All models, in the order of SPEC §3–4.
const std::vector<ModelKind>& allModelKinds();
/// The names of the models (in table order, "mean, uniform, …"); with a 2D TF (SPEC §9) only
/// those with a 2D classification.
std::string modelNames(bool twoD = false);
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
