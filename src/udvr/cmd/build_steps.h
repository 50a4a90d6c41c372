#pragma once
// What the two drivers of `udvr build` share (cmd_build.cpp registers the command): the flags,
// the memory limit and the slab plan, opening the input as slabs, fitting the options to the
// samples per voxel. The drivers: one process (build_local.cpp) and one MPI rank of a
// partitioned build (build_ranks.cpp).
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "udvr/cmd/parse_util.h"
#include "udvr/io/ensemble_io.h"
#include "udvr/io/field_io.h"
#include "udvr/stats/build_model.h"
#include "udvr/util/progress.h"

namespace udvr::cmd {

/// The flags of `udvr build`.
struct BuildFlags {
    std::vector<std::string> inputs;
    std::string out, density, bandwidth = "silverman", var, memberDim, levels, nan = "error";
    int quantiles = 8, gmm = 4, downsample = 0, pieces = 0;
    double tailEps = 0.0;
    CLI::Option* downsampleOpt = nullptr;
    CLI::Option* tailEpsOpt = nullptr;
    CLI::Option* gmmOpt = nullptr;
    CLI::Option* quantilesOpt = nullptr;
    std::string memoryLimit = "auto";
    int slabHeight = 0;
    CLI::Option* slabHeightOpt = nullptr;
    RawLayoutFlags raw;  // headerless .raw inputs
    bool noCompress = false;
};

/// How much an out-of-core build may hold (--memory-limit), and why, for the plan's line.
struct MemoryLimit {
    std::size_t bytes = 0;
    std::string text;
};

/// --memory-limit: BYTES, or auto (half of the available memory).
MemoryLimit parseMemoryLimit(const std::string& value);

/// Wall seconds since t.
double secondsSince(std::chrono::steady_clock::time_point t);

/// Fit the options to n samples per voxel (the library's rule); what was fitted is added to
/// `notes` for stderr (said once the input has been checked, so that an error stays the one line).
void fitOptionsToSamples(BuildOptions& opt, long long samples, bool gmmGiven, bool quantilesGiven,
                         std::string& notes);

/// The slab height in model z-planes: --slab-height (input planes, a multiple of K), or the
/// most that fit the limit; 0 where the whole volume fits (the in-memory build).
int planSlabs(const BuildMemory& mem, const MemoryLimit& limit, int modelZ, int k, int forced,
              const std::string& what);

/// One progress bar per slab and pass.
struct SlabBars {
    std::unique_ptr<ProgressBar> bar;
    ProgressBar* next(const char* pass, int slab, int slabs, std::size_t voxels) {
        bar.reset();
        bar = std::make_unique<ProgressBar>(std::string("build ") + pass + " slab " +
                                                std::to_string(slab + 1) + "/" +
                                                std::to_string(slabs),
                                            voxels);
        return bar.get();
    }
};

/// What the streamed builds read from an opened input.
SlabInput slabInputOf(const SlabReader& r);

/// The one field that --downsample K reduces, as slabs; an ensemble file is a one-line error.
SlabReader openBrickedField(const std::vector<std::string>& inputs, const FieldReadOptions& ro);

/// Ensemble inputs: one field without --downsample is a one-line error.
void requireEnsembleInputs(const std::vector<std::string>& inputs);

/// One build on this process (no MPI; build_local.cpp): in memory, or out of core a slab at a
/// time into a streamed .vti; then the report on stderr.
void runLocalBuild(const BuildFlags& f, BuildOptions opt, MemoryLimit limit);

/// `mpirun -np N udvr build … -o m.pvti` (mpi_job.h; docs/formats.md, "Partitioned models"):
/// the model's z-planes split into N pieces (pvtiPieceBoundaries: neighbours share a plane).
/// Rank r streams piece r's planes (BuildOptions::modelPlanes: every rank scans the whole input,
/// so the range, the NaN/Inf checks and every voxel are the single build's, bit for bit) and
/// writes its piece; rank 0 writes the header once every piece is written. k: --downsample K, or
/// 0 for an ensemble. An error of any rank is said once, by rank 0 (agreeOrThrow;
/// build_ranks.cpp).
void buildOnRanks(const std::vector<std::string>& inputs, const std::string& out, int k,
                  const EnsembleReadOptions& ro, BuildOptions opt, const MemoryLimit& limit,
                  int forcedSlab, bool gmmGiven, bool quantilesGiven);

}  // namespace udvr::cmd
