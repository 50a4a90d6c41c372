#pragma once
// `udvr build`'s library half (SPEC §2): per-voxel samples from an ensemble or from K³ bricks of
// one field → a ModelVolume with moments, quantile boundaries, IQR and a GMM.
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "udvr/stats/gmm.h"
#include "udvr/stats/model_volume.h"
#include "udvr/stats/voxel_stats.h"
#include "udvr/util/field.h"

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
    /// Streamed builds only (one MPI rank's share): the model z-planes [begin, end) to compute
    /// and hand to the sink; end < 0: all. The scans still read the whole input, so the range,
    /// the NaN/Inf checks and each voxel's values are the whole build's, bit for bit.
    struct PlaneRange {
        int begin = 0, end = -1;
    } modelPlanes;
    /// In-memory builds of a piece of a larger grid (ParaView's Build Model filter: one MPI
    /// rank's piece, whole x-y planes): the only two things a voxel's values take from outside
    /// its own samples are set to the whole grid's, so the piece's values are the whole build's,
    /// bit for bit. firstVoxel: the whole grid's index of the input's voxel 0 (a voxel's GMM
    /// random stream is firstVoxel + its index in the input); wholeMin ≤ wholeMax: the whole
    /// input's data range, for the GMM's σ floor (wholeMin > wholeMax: the input's own).
    struct Piece {
        std::uint64_t firstVoxel = 0;
        double wholeMin = 1.0, wholeMax = 0.0;
    } piece;
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
    int slabs = 0;             // out-of-core builds: slabs of z-planes (0: in memory)
    int inputPasses = 0;       // out-of-core builds: reads of the whole input (1 to 3)
    double readSeconds = 0.0;  // out-of-core builds: wall time reading the input (all passes)
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

// ---- out of core (issue 15) -------------------------------------------------------------------
// An input read a slab of whole z-planes at a time, the model handed on a slab at a time: the
// same model, bit for bit, in memory for one slab. Every voxel's statistics depend on its own
// samples, the whole input's range (the GMM's σ floor) and its index (the GMM's random stream)
// only; so the input is read twice: a scan of the range and NaN/Inf first, then the statistics
// (once without a GMM under NanPolicy::Error: nothing else needs the range, and a slab with
// NaN/Inf ends the build).

/// Fills planes [z0, z1) of every member (one for a field), member-major: member m's planes at
/// out[m·(z1 − z0)·X·Y …], x fastest.
using SlabRead = std::function<void(int z0, int z1, std::span<float> out)>;
/// Receives the model's voxels [first, first + slab.mean.size()): whole z-planes of the model
/// grid, in order.
using SlabSink = std::function<void(const ModelVolume& slab, std::size_t first)>;
/// Called before each slab of each pass ("scan", "count" (--nan skip), "build"; slab of slabs,
/// voxels in it); returns the progress bar to advance by voxels (may be null).
using SlabProgress =
    std::function<ProgressBar*(const char* pass, int slab, int slabs, std::size_t voxels)>;

/// An input to stream: its grid, members (1 for a field) and value type (as Ensemble's).
struct SlabInput {
    Grid3 grid;
    int members = 0;
    double valueStep = 0.0;
    std::string valueType;
    SlabRead read;
};

/// Bytes of the arrays of one model voxel with these options (mean, stddev, min, max, IQR,
/// q + 1 boundaries, 3K GMM parameters).
std::size_t modelBytesPerVoxel(const BuildOptions& options);

/// What an out-of-core build holds in memory, to choose its slab height.
struct BuildMemory {
    /// Bytes per model z-plane of a slab: its input planes (members × K planes × X × Y floats
    /// and the reader's scratch for them) and the model arrays of its voxels.
    std::size_t perPlane = 0;
    /// Bytes whatever the slab: kde's bandwidth per model voxel, the threads' sample buffers,
    /// the reader's fixed scratch (a member read whole) and the model writer's buffers.
    std::size_t fixed = 0;
    /// The most model z-planes a slab may have under `limit` bytes (0: not even one).
    int planesWithin(std::size_t limit) const {
        if (limit <= fixed || perPlane == 0) return 0;
        const std::size_t planes = (limit - fixed) / perPlane;
        return planes > (1u << 30) ? (1 << 30) : static_cast<int>(planes);
    }
};

/// BuildMemory of a build from `input` (members × X × Y × Z; K = k for bricks, 1 for an
/// ensemble) with these options; the reader's scratch per input plane and fixed.
BuildMemory buildMemory(const Grid3& input, int members, int k, const BuildOptions& options,
                        std::size_t readerScratchPerPlane, std::size_t readerScratchFixed);

/// buildModel reading `slabPlanes` z-planes at a time (the last slab may be thinner); the
/// arrays go to `sink` slab by slab, the returned model holds the field data only. Same
/// errors as buildModel.
ModelVolume buildModelStreamed(const SlabInput& input, int slabPlanes, const BuildOptions& options,
                               const SlabSink& sink, const SlabProgress& progress = {},
                               BuildReport* report = nullptr);

/// buildModelDownsampled reading `slabBricks`·K field z-planes (slabBricks reduced planes) at a
/// time; input.members must be 1. As buildModelStreamed otherwise.
ModelVolume buildModelDownsampledStreamed(const SlabInput& input, int k, int slabBricks,
                                          const BuildOptions& options, const SlabSink& sink,
                                          const SlabProgress& progress = {},
                                          BuildReport* report = nullptr);

}  // namespace udvr
