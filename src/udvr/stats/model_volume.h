#pragma once
// The model volume: per-voxel distribution models (SPEC §2, §7). Written by `udvr build`,
// read by render/probe. Arrays are empty when the model was not built.
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "udvr/util/field.h"
#include "udvr/util/grid.h"

namespace udvr {

struct ModelVolume {
    Grid3 grid;  // the model's own (possibly reduced) grid, world units

    std::vector<float> mean;    // μ per voxel
    std::vector<float> stddev;  // σ per voxel, ddof = 1 (0 for a single sample)
    std::vector<float> min;     // sample minimum per voxel
    std::vector<float> max;     // sample maximum per voxel

    int quantileCount = 0;         // q; quantiles holds q+1 boundaries per voxel (0 = absent)
    std::vector<float> quantiles;  // b_0..b_q contiguous per voxel: quantiles[v*(q+1)+j]
    std::vector<float> iqr;        // b(0.25), b(0.75) per voxel (empty = absent)
    /// The levels t_0 = 0 < … < t_q = 1 of the boundaries (SPEC §7 `quantile_levels`), quantile
    /// j holding mass t_j − t_{j−1}; empty: even, t_j = j/q (evenLevels normalises to empty).
    std::vector<double> quantileLevels;

    int gmmComponents = 0;   // K (0 = absent)
    std::vector<float> gmm;  // 3K per voxel: π_1..π_K, μ_1..μ_K, σ_1..σ_K; sorted by μ

    // The ensemble itself, for the `members` reference (membersModel); never written to a file.
    int memberCount = 0;         // n (0 = absent)
    std::vector<float> members;  // n per voxel, voxel-major: members[v*n + i]

    // Field data (SPEC §7).
    std::string density = "empirical";  // "empirical", "kde" or "dequantized"
    double bandwidth = 0.0;     // kde: median h over voxels (rule may vary); dequantized: step s
    std::string bandwidthRule;  // "silverman", "scott", a number, or "" (empirical)
    double tailEps = 0.0;       // kde tail ε; 0 for empirical
    int samplesPerVoxel = 0;
    int downsample = 0;              // brick size K, 0 for an ensemble
    std::array<double, 6> bounds{};  // full-resolution world bounds
    double fullResMinSpacing = 1.0;  // smallest spacing of the full-resolution grid
    std::string source;              // input description
    /// Field data `default_tf`: the full-resolution field's default-TF basis, recorded by
    /// `build --downsample` (tf_presets.h DefaultTfBasis); empty: the basis of the model's means.
    std::vector<double> defaultTf;

    /// Records the input's full-resolution grid: its bounds and smallest spacing, and the brick
    /// size K of a downsampled build (0: an ensemble or a field on its own grid).
    void setFullResolution(const Grid3& full, int brick) {
        downsample = brick;
        bounds = full.bounds();
        fullResMinSpacing = full.minSpacing();
    }
    std::size_t voxelCount() const { return grid.pointCount(); }
    bool hasQuantiles() const { return quantileCount > 0 && !quantiles.empty(); }
    /// t_j of boundary j (j/q for even levels).
    double quantileLevel(int j) const {
        return quantileLevels.empty() ? static_cast<double>(j) / quantileCount
                                      : quantileLevels[static_cast<std::size_t>(j)];
    }
    /// The boundary j at level t (within 1e−9), or −1 where no boundary sits there.
    int boundaryAtLevel(double t) const {
        for (int j = 0; j <= quantileCount; ++j)
            if (std::abs(quantileLevel(j) - t) <= 1e-9) return j;
        return -1;
    }
    /// The levels for the kernels: null for even levels.
    const double* levelsOrNull() const {
        return quantileLevels.empty() ? nullptr : quantileLevels.data();
    }
    bool hasGmm() const { return gmmComponents > 0 && !gmm.empty(); }
    const float* quantilesAt(std::size_t v) const {
        return quantiles.data() + v * static_cast<std::size_t>(quantileCount + 1);
    }
    const float* gmmAt(std::size_t v) const {
        return gmm.data() + v * static_cast<std::size_t>(3 * gmmComponents);
    }
};

/// A per-voxel array of a model file (SPEC §7): its name and member, and its floats per voxel.
struct ModelFileArray {
    enum class Arity { One, Pair, Quantiles, Gmm };
    const char* name;
    std::vector<float> ModelVolume::*values;
    Arity arity;
    /// Floats per voxel in a model of q quantiles and K components: 1, 2, q + 1 or 3K; 0 for
    /// quantiles without q and a GMM without K (the array is absent).
    constexpr int floatsPerVoxel(int q, int k) const {
        switch (arity) {
            case Arity::One:
                return 1;
            case Arity::Pair:
                return 2;
            case Arity::Quantiles:
                return q > 0 ? q + 1 : 0;
            case Arity::Gmm:
                return 3 * k;
        }
        return 0;
    }
    int floatsPerVoxel(const ModelVolume& m) const {
        return floatsPerVoxel(m.quantileCount, m.gmmComponents);
    }
};

/// Every per-voxel array a model file holds, in the order it is written (SPEC §7). The
/// `members` of the ensemble reference are not a file array.
inline constexpr ModelFileArray kModelFileArrays[] = {
    {"mean", &ModelVolume::mean, ModelFileArray::Arity::One},
    {"stddev", &ModelVolume::stddev, ModelFileArray::Arity::One},
    {"min", &ModelVolume::min, ModelFileArray::Arity::One},
    {"max", &ModelVolume::max, ModelFileArray::Arity::One},
    {"quantiles", &ModelVolume::quantiles, ModelFileArray::Arity::Quantiles},
    {"iqr", &ModelVolume::iqr, ModelFileArray::Arity::Pair},
    {"gmm", &ModelVolume::gmm, ModelFileArray::Arity::Gmm},
};

/// Checks quantile levels for q quantiles (q + 1 values, t_0 = 0, strictly increasing, t_q = 1)
/// and returns them, or an empty vector where every t_j is within 1e−9 of j/q (even levels, so
/// that even levels given explicitly give exactly the images of the even default). `what` names
/// the source in the UdvrError thrown otherwise.
std::vector<double> normalizedQuantileLevels(const std::vector<double>& levels, int q,
                                             const std::string& what);

/// Largest standard deviation (stddev, a GMM component's σ) a model may hold: the kernels square
/// σ in float (σ², Σ w²σ²), which overflows past 1.8e19; a stddev of 3e38 drew NaN pixels
/// (issue 34).
inline constexpr double kMaxModelSigma = 1e18;

/// Throws UdvrError "WHAT: array 'stddev' is negative (-0.5) at voxel (3, 4, 5)" (voxel (i, j, k),
/// i along x) for what no model built by `udvr build` holds and the kernels do not expect: NaN or
/// Inf in any array, a negative stddev or one over kMaxModelSigma, min > max, quantile boundaries
/// or an iqr pair that decrease, GMM weights outside [0, 1], negative or over-large GMM σ.
/// Called where a model is read or made (the .vti/.pvti reader, Python's Model), so that no
/// kernel sees such values. The arrays' sizes are the caller's to check.
void checkModelArrays(const ModelVolume& m, const std::string& what);

/// The ensemble as the `members` reference (no model, issue 12): its members voxel-major (a
/// member-major ensemble is transposed, a voxel-major one moved), their mean per voxel (framing,
/// TF presets, probe's "value"), its grid, bounds and spacing; samplesPerVoxel = n.
ModelVolume membersModel(Ensemble ensemble);

/// A deterministic field as a model: mean = min = max = the values, stddev = 0; no quantiles or
/// GMM. Rendering it with model `mean` is the ground truth of SPEC §5.
ModelVolume modelFromField(const ScalarField& field);

}  // namespace udvr
