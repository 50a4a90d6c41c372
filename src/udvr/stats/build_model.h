#pragma once
// `udvr build`'s library half (SPEC §2): per-voxel samples from an ensemble or from K³ bricks of
// one field → a ModelVolume with moments, quantile boundaries, IQR and a GMM.
#include <cstdint>
#include <string>
#include <vector>

#include "udvr/io/field.h"
#include "udvr/stats/gmm.h"
#include "udvr/stats/model_volume.h"
#include "udvr/stats/voxel_stats.h"

namespace udvr {

class ProgressBar;

/// What build does with NaN/Inf samples (`--nan`).
enum class NanPolicy {
    Error,  // refuse the input, naming the first voxel (i,j,k) and member
    Skip,   // each voxel's statistics over its finite samples only (≥ 2 at every voxel)
};

/// Parse "error" | "skip"; throws UdvrError otherwise.
NanPolicy parseNanPolicy(const std::string& name);

struct BuildOptions {
    int quantiles = 8;  // q ≥ 1; 0 skips the quantile array
    /// q + 1 levels t_0 = 0 < … < t_q = 1 of the boundaries (`--quantile-levels`); empty: j/q.
    std::vector<double> quantileLevels;
    int gmmComponents = 4;  // K ≥ 1; 0 skips the GMM
    DensityEstimate density = DensityEstimate::Empirical;
    KdeBandwidth bandwidth;                   // kde only
    std::string bandwidthText = "silverman";  // as given, for the field data
    double tailEps = 0.0;                     // kde tail ε in (0, 0.5) and ≤ 1/q; 0 = 1/(2n)
    NanPolicy nan = NanPolicy::Error;         // NaN/Inf samples
    std::uint64_t gmmSeed = 1;                // k-means++ seed
    std::string source;                       // input description for the field data
    ProgressBar* progress = nullptr;          // advanced by voxels done (may be null)
};

/// What a build did, for the summary line.
struct BuildReport {
    std::size_t voxels = 0;
    int samplesPerVoxel = 0;
    std::size_t constantVoxels = 0;    // all samples equal: point masses
    std::size_t gmmNotConverged = 0;   // EM stopped at 100 iterations
    std::size_t gmmFewerDistinct = 0;  // voxels with fewer distinct values than K
    double meanGmmIterations = 0.0;
    std::size_t nonFiniteSamples = 0;           // --nan skip: NaN/Inf samples left out
    std::size_t voxelsWithNonFinite = 0;        // --nan skip: voxels that had any
    int fewestFiniteSamples = 0;                // --nan skip: min over voxels of the finite samples
    double dataMin = 0.0, dataMax = 0.0;        // over all samples
    std::array<int, 3> droppedPlanes{0, 0, 0};  // downsampling: trailing N mod K planes per axis
    double seconds = 0.0;                       // check + statistics
    /// CPU seconds of each stage, summed over the threads (thread CPU clocks, so another
    /// process on the same cores does not inflate them): the NaN/range scan, the gather of a
    /// chunk's samples, sorting + moments + quantiles + IQR, and the GMM (seeding and EM).
    double scanCpu = 0.0, gatherCpu = 0.0, estimateCpu = 0.0, gmmCpu = 0.0;
};

/// Check options against n samples per voxel; throws UdvrError (q < 0, K < 0 or K > n, K too
/// large, ε out of range, bandwidth not positive).
void validateBuildOptions(const BuildOptions& options, int samplesPerVoxel);

/// The density estimate `build` uses when none is given: kde (Silverman's bandwidth) for K³
/// bricks of one field, empirical for ensembles (BuildOptions' own default is empirical).
/// Bricks: the minimax-regret choice of `udvr experiment downsample-estimators` over the
/// spheres, chest, neghip and tooth volumes (docs/experiments.md); ensembles: `tangle-sweep`.
DensityEstimate defaultDensity(bool bricks);

/// Check the density estimate against the input (ScalarField::valueStep, valueType): dequantized
/// needs a quantisation step > 0, i.e. integer-typed values; throws UdvrError naming the type.
void checkDensityForInput(DensityEstimate density, double valueStep, const std::string& valueType);

/// What fitBuildOptionsToSamples changed or noticed, for the user: one warning per option given
/// explicitly, and one info text for the defaults (empty when nothing).
struct BuildFitNotes {
    std::vector<std::string> warnings;
    std::string info;
};

/// Fit the GMM and quantile counts to n samples per voxel, then check every option against n
/// (validateBuildOptions): a K-component GMM needs n ≥ K samples (fitGmm), so a larger K is
/// lowered to n; empirical quantiles with q > n only interpolate between the n order statistics
/// (kde quantiles come from the smooth density, so they are not mentioned). `gmmGiven` /
/// `quantilesGiven`: the user chose K / q (a warning each) rather than the defaults (one info
/// text together). The CLI and the Python module say the notes after this returned, so an error
/// stays the one message.
BuildFitNotes fitBuildOptionsToSamples(BuildOptions& options, long long samplesPerVoxel,
                                       bool gmmGiven, bool quantilesGiven);

/// Model from an ensemble: the members' values at a voxel are its samples. Throws UdvrError for
/// fewer than 2 members, non-finite samples (NanPolicy::Error: their count, the first voxel and
/// its member; Skip: a voxel with fewer than 2 finite samples) or dequantized on a float
/// ensemble (checkDensityForInput).
ModelVolume buildModel(const Ensemble& ensemble, const BuildOptions& options,
                       BuildReport* report = nullptr);

/// The reduced grid of K³ bricks (SPEC §2): ⌊N/K⌋ points per axis, spacing K·spacing, origin
/// + (K−1)/2·spacing. Throws UdvrError for K < 2 or K larger than a dimension.
Grid3 downsampledGrid(const Grid3& full, int k);

/// Model from one field, each K³ brick's values being the samples of its reduced voxel (NaN/Inf
/// as in buildModel: the first point, or with Skip the brick's finite values only).
ModelVolume buildModelDownsampled(const ScalarField& field, int k, const BuildOptions& options,
                                  BuildReport* report = nullptr);

}  // namespace udvr
