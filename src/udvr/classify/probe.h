#pragma once
// `udvr probe` (SPEC §8): the reconstructed distribution (SPEC §3) and its expected TF (SPEC §4)
// at one index-space point, as data for JSON, a summary and a PDF plot.
#include <array>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "udvr/classify/model_families.h"
#include "udvr/classify/model_kind.h"
#include "udvr/classify/transfer_function.h"
#include "udvr/classify/transfer_function_2d.h"
#include "udvr/stats/model_volume.h"

namespace udvr {

/// The distribution at a point: continuous part given by its CDF, plus point masses.
struct ProbeDistribution {
    double lo = 0.0, hi = 0.0;            // plot range holding (almost) all the mass, data units
    double continuousMass = 0.0;          // total mass of the continuous part (0 or 1)
    std::vector<double> atoms, atomMass;  // point masses: positions and probabilities
    std::vector<double> cdfX, cdfY;       // continuous CDF sampled on a fine grid over [lo, hi]
};

struct ProbeResult {
    ModelKind kind;
    std::array<double, 3> point;  // index space
    Rgba expected;        // (E[α·r], E[α·g], E[α·b], E[α]), before opacity correction
    nlohmann::json json;  // SPEC §8 object: model, point, world, grid_dims, expected_rgba, …
    ProbeDistribution distribution;
};

/// Reconstruct and classify at index-space `point` (inside the grid, else UdvrError).
ProbeResult probeModel(const ModelVolume& model, ModelKind kind, const TransferFunction1D& tf,
                       const std::array<double, 3>& point, const ClassifyOptions& options = {});

/// probe with a 2D TF (SPEC §9): the JSON adds "gradient" (μ_Y, world units),
/// "gradient_magnitude" {"mean", "stddev"} of G and, for the quantile models, "polyline" {"x",
/// "g"} (the rank-coupled vertices).
ProbeResult probeModel(const ModelVolume& model, ModelKind kind, const TransferFunction2D& tf,
                       const std::array<double, 3>& point, const ClassifyOptions& options = {});

/// probe bivariate fields with a 2D TF (SPEC §9 `--second`): x from `first`, y from `second`
/// (same grid, the same model kind). The JSON adds "second" {"value", "mean", "stddev"} (the
/// second field's mean at the point and its distribution's mean and standard deviation) and, as
/// the value × gradient probe, "gradient_magnitude" {"mean", "stddev"} of field 2.
ProbeResult probeBivariate(const ModelVolume& first, const ModelVolume& second, ModelKind kind,
                           const TransferFunction2D& tf, const std::array<double, 3>& point,
                           const ClassifyOptions& options = {});

/// World position of an index-space point: origin + index·spacing (SPEC §1).
std::array<double, 3> worldFromIndex(const Grid3& grid, const std::array<double, 3>& index);
/// Index-space point of a world position; throws UdvrError naming `what` ("--world 1,2,3")
/// when it lies outside the grid.
std::array<double, 3> indexFromWorld(const Grid3& grid, const std::array<double, 3>& world,
                                     const std::string& what);

}  // namespace udvr
