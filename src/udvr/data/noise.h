#pragma once
// Noise models for `udvr perturb`: an ensemble of members = truth + i.i.d. noise per voxel.
// All magnitudes are fractions of the field's value range R = max − min, so one set of defaults
// serves fields of any scale.
#include <cstdint>
#include <string>

#include "udvr/util/field.h"

namespace udvr {

enum class NoiseKind {
    Bimodal,   // Athawale et al. 2021 §5: 80 % around the truth, 20 % outliers to one side
    Gaussian,  // truth + N(0, (sigma·R)²)
    Uniform,   // truth + U[−width·R, +width·R]
};

struct NoiseParams {
    NoiseKind kind = NoiseKind::Bimodal;
    double sigma = 0.02;           // main-mode / gaussian std, × R
    double width = 0.05;           // uniform half-width, × R
    double outlierFraction = 0.2;  // bimodal: probability of the outlier mode
    double outlierOffset = 0.2;    // bimodal: outlier mode centre, truth + offset·R (one side)
    double outlierSigma = 0.04;    // bimodal: outlier mode std, × R
    std::uint64_t seed = 1;
};

/// Parse "bimodal" | "gaussian" | "uniform"; throws UdvrError otherwise.
NoiseKind parseNoiseKind(const std::string& name);

/// Make `members` noisy copies of `truth` (member-major). Deterministic in (params, member,
/// voxel): the same seed gives the same ensemble for any thread count. Throws for members < 2.
Ensemble perturbField(const ScalarField& truth, int members, const NoiseParams& params);

}  // namespace udvr
