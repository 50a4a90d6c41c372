// udvr build {ensemble.nc | member files… | 'glob*' | field --downsample K} [--quantiles 8]
//   [--gmm 4] [--density empirical|kde|dequantized] [--bandwidth silverman|scott|H]
//   [--tail-eps E] [--var NAME] [--member-dim NAME] [--nan error|skip]
//   [--memory-limit BYTES|auto] [--slab-height N] -o model.vti          (SPEC §2, §7, §8; issue 15)
//   The flags and their checks; the drivers: build_local.cpp (one process), build_ranks.cpp (MPI).
#include <algorithm>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "udvr/cmd/build_steps.h"
#include "udvr/cmd/commands.h"
#include "udvr/cmd/mpi_job.h"
#include "udvr/cmd/parse_util.h"
#include "udvr/io/field_io.h"
#include "udvr/stats/build_model.h"
#include "udvr/util/check.h"

namespace udvr::cmd {
namespace {

/// BuildOptions from the flags, with every check that needs no input.
BuildOptions buildOptionsOf(const BuildFlags& f) {
    BuildOptions opt;
    opt.quantiles = f.quantiles;
    if (!f.levels.empty()) {
        opt.quantileLevels = parseDoubleList(f.levels, "--quantile-levels");
        const int q = static_cast<int>(opt.quantileLevels.size()) - 1;
        if (f.quantilesOpt->count() > 0 && f.quantiles != q)
            UDVR_FAIL("--quantiles " << f.quantiles << " disagrees with the " << q + 1
                                     << " values of --quantile-levels (q + 1 boundaries)");
        opt.quantiles = q;
    }
    opt.gmmComponents = f.gmm;
    opt.nan = parseNanPolicy(f.nan);
    const bool bricks = f.downsampleOpt->count() > 0;
    opt.density = f.density.empty() ? defaultDensity(bricks) : parseDensityEstimate(f.density);
    opt.bandwidthText = f.bandwidth;
    if (opt.density == DensityEstimate::Kde) opt.bandwidth = parseBandwidth(f.bandwidth);
    if (f.tailEpsOpt->count() > 0) {
        if (!(f.tailEps > 0.0))
            UDVR_FAIL("--tail-eps " << f.tailEps << " is out of range; expected 0 < E < 0.5");
        opt.tailEps = f.tailEps;
    }
    // What does not depend on the input is checked before it is read (the sample count
    // is then assumed large enough; fitOptionsToSamples checks against the real one).
    validateBuildOptions(opt, std::numeric_limits<int>::max());
    if (f.slabHeightOpt->count() > 0 && f.slabHeight < 1)
        UDVR_FAIL("--slab-height " << f.slabHeight
                                   << " is out of range; expected a number of z-planes >= 1");
    if (f.slabHeightOpt->count() > 0 && bricks && f.downsample >= 2 &&
        f.slabHeight % f.downsample != 0)
        UDVR_FAIL("--slab-height " << f.slabHeight << " is not a multiple of --downsample "
                                   << f.downsample
                                   << "; bricks need whole K-plane slabs, e.g. --slab-height "
                                   << std::max(f.slabHeight / f.downsample, 1) * f.downsample);
    for (const std::string& in : f.inputs) opt.source += (opt.source.empty() ? "" : " ") + in;
    if (bricks) opt.source += " --downsample " + std::to_string(f.downsample);
    return opt;
}

}  // namespace

void addBuildCommand(CLI::App& app) {
    auto* sub = app.add_subcommand(
        "build",
        "per-voxel distribution models (moments, quantiles, IQR, GMM) from an ensemble "
        "or from K^3 bricks of one field, written as a .vti model");
    auto o = std::make_shared<BuildFlags>();
    sub->add_option("inputs", o->inputs,
                    "ensemble .nc, member files or quoted globs ('m_*.vti'), or one field with "
                    "--downsample")
        ->required();
    o->downsampleOpt = sub->add_option(
        "--downsample", o->downsample,
        "K: model one field's K^3 bricks (reduced grid floor(N/K) per axis, at brick centres)");
    o->quantilesOpt = sub->add_option("--quantiles", o->quantiles,
                                      "q quantiles, q+1 boundaries (default 8; 0 skips)");
    sub->add_option("--quantile-levels", o->levels,
                    "t_0,t_1,...,t_q: uneven quantile levels, increasing from 0 to 1 (q from "
                    "their count; default j/q)");
    o->gmmOpt = sub->add_option("--gmm", o->gmm,
                                "GMM components K (default 4, lowered to the samples per voxel "
                                "when there are fewer; 0 skips)");
    sub->add_option("--density", o->density,
                    "empirical | kde | dequantized (integer-typed input: each value spread over "
                    "its quantisation step) (default: kde with --downsample, else empirical)");
    sub->add_option("--bandwidth", o->bandwidth,
                    "kde bandwidth: silverman | scott | H in data units (default silverman)");
    o->tailEpsOpt = sub->add_option("--tail-eps", o->tailEps,
                                    "kde tail probability of b_0 and b_q (default 1/(2n))");
    sub->add_option("--var", o->var, "variable/array to read");
    sub->add_option("--member-dim", o->memberDim, "NetCDF member dimension name");
    sub->add_option("--nan", o->nan,
                    "NaN/Inf samples (and NetCDF fill values): error (default; names the first "
                    "voxel and member) | skip (each voxel from its finite samples, at least 2)");
    sub->add_option("--memory-limit", o->memoryLimit,
                    "BYTES (512M, 4G, ...) or auto (default: half of the available memory): "
                    "an input and model larger than this are built out of core, a slab of "
                    "z-planes at a time (the same model, bit for bit)");
    o->slabHeightOpt = sub->add_option(
        "--slab-height", o->slabHeight,
        "N: build out of core in slabs of N input z-planes (a multiple of K with --downsample) "
        "whatever the memory (for tests)");
    sub->add_flag("--no-compress", o->noCompress,
                  "write the model's arrays raw (.vti, built in memory); default: LZ4-compressed, "
                  "as ParaView writes and reads");
    sub->add_option("-o,--output", o->out,
                    "output model: .vti, or .pvti (VTK's parallel ImageData: the model in "
                    "z-pieces <stem>/<stem>_<i>.vti, which ParaView opens in parallel)")
        ->required();
    sub->add_option("--pieces", o->pieces,
                    "with -o .pvti: how many z-pieces (default: one per thread; at most one per "
                    "cell layer)");
    addRawLayoutOptions(sub, o->raw);

    sub->callback([o] {
        o->inputs = withOneMatchResolved(o->inputs);  // a quoted glob of one file is that file
        requireOutputExtension(o->out, "-o", {".vti", ".pvti"},
                               "build writes a model as VTK ImageData");
        const bool partitioned = lowerExtension(o->out) == ".pvti";
        if (o->pieces != 0 && !partitioned)
            UDVR_FAIL("--pieces " << o->pieces << " needs -o with a .pvti (partitioned) model");
        if (o->pieces < 0 || o->pieces > 65536)
            UDVR_FAIL("--pieces " << o->pieces << " is out of range; expected 1 to 65536");
        const BuildOptions opt = buildOptionsOf(*o);
        const MemoryLimit limit = parseMemoryLimit(o->memoryLimit);
        const int forcedSlab = o->slabHeightOpt->count() > 0 ? o->slabHeight : 0;
        const bool bricks = o->downsampleOpt->count() > 0;
        const bool skipNan = opt.nan == NanPolicy::Skip;
        requireOutputsNotInputs({{"-o", o->out}}, o->inputs);
        if (o->noCompress && partitioned)
            UDVR_FAIL("--no-compress writes a .vti; a .pvti's pieces are LZ4-compressed");
        requireOutputDirectory(o->out, "-o");
        const MpiJob& job = mpiJob();
        if (job.launchedWithoutMpi)
            UDVR_FAIL(
                "started by an MPI launcher, but this udvr was built without MPI "
                "(-DUDVR_MPI=ON): every copy would build the whole model into the same file");
        if (job.active) {
            if (!partitioned)
                UDVR_FAIL(
                    "under mpirun, build writes one z-piece per rank: -o needs a .pvti "
                    "(partitioned) model, got "
                    << o->out);
            if (o->pieces != 0 && o->pieces != job.size)
                UDVR_FAIL("--pieces " << o->pieces << " under mpirun: the pieces are the "
                                      << job.size << " ranks");
            EnsembleReadOptions ro;
            ro.var = o->var;
            ro.memberDim = o->memberDim;
            ro.raw = toRawLayout(o->raw);
            ro.allowMissing = skipNan;
            buildOnRanks(o->inputs, o->out, bricks ? o->downsample : 0, ro, opt, limit, forcedSlab,
                         o->gmmOpt->count() > 0, o->quantilesOpt->count() > 0);
            return;
        }
        runLocalBuild(*o, opt, limit);
    });
}

}  // namespace udvr::cmd
