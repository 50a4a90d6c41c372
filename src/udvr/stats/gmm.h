#pragma once
// Gaussian mixture fit of one voxel's samples by EM (SPEC §2): k-means++ seeding from a fixed
// seed, σ ≥ a floor (1e−3 of the data range), at most 100 iterations or a change of the mean
// per-sample log-likelihood below 1e−6, components sorted by mean.
#include <cstdint>
#include <span>
#include <vector>

namespace udvr {

/// Largest supported K.
constexpr int kMaxGmmComponents = 32;

struct GmmOptions {
    int components = 4;        // K in [1, kMaxGmmComponents]
    double sigmaFloor = 1e-3;  // σ_k ≥ this, data units (> 0)
    int maxIterations = 100;   // EM iterations
    double tolerance = 1e-6;   // stop when |Δ mean log-likelihood per sample| < tolerance
    std::uint64_t seed = 1;    // k-means++ seed; the voxel index is the stream
};

/// What one fit did.
struct GmmFitInfo {
    int iterations = 0;              // EM iterations run
    bool converged = true;           // tolerance reached (or nothing to iterate)
    int distinctComponents = 0;      // components with weight > 0 (< K when the voxel has fewer
                                     // distinct values than K)
    double meanLogLikelihood = 0.0;  // per sample, at the final parameters
};

/// Scratch buffers reused across voxels by one thread (no allocation per voxel).
struct GmmWorkspace {
    std::vector<double> d2;    // k-means++ distances
    std::vector<float> lanes;  // 16 voxels' samples, interleaved
};

/// Fit a K-component mixture to `sorted` (ascending, n ≥ 1) and write 3K floats to `out`:
/// π_1..π_K, μ_1..μ_K, σ_1..σ_K with μ ascending. `stream` (the voxel index) makes the seeding
/// independent of thread scheduling. A voxel with d < K distinct values gets d fitted components
/// and K − d spare ones with π = 0, μ = the sample mean, σ = the floor (so n < K samples give at
/// most n components); a constant voxel is a point mass (π_1 = 1, every μ = the value, every σ =
/// the floor).
GmmFitInfo fitGmm(std::span<const float> sorted, const GmmOptions& options, std::uint64_t stream,
                  std::span<float> out, GmmWorkspace& ws);

/// fitGmm for many voxels of n samples each: voxel v's sorted samples are sorted[v·n, (v+1)·n),
/// its stream firstStream + v, its 3K outputs out[v·3K …] and its info info[v]. The voxels are
/// fitted 16 at a time, one per vector lane (a lane takes the next voxel as soon as its own has
/// stopped); every voxel's result is bit-identical to fitGmm's.
void fitGmmMany(std::span<const float> sorted, std::size_t n, const GmmOptions& options,
                std::uint64_t firstStream, std::span<float> out, std::span<GmmFitInfo> info,
                GmmWorkspace& ws);

}  // namespace udvr
