// udvr build {ensemble.nc | member files… | 'glob*' | field --downsample K} [--quantiles 8]
//   [--gmm 4] [--density empirical|kde|dequantized] [--bandwidth silverman|scott|H]
//   [--tail-eps E] [--var NAME] [--member-dim NAME] [--nan error|skip] -o model.vti
//                                                                            (SPEC §2, §7, §8)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "udvr/cmd/commands.h"
#include "udvr/cmd/parse_util.h"
#include "udvr/io/ensemble_io.h"
#include "udvr/io/field_io.h"
#include "udvr/io/model_io.h"
#include "udvr/stats/build_model.h"
#include "udvr/util/check.h"
#include "udvr/util/parallel.h"
#include "udvr/util/progress.h"

namespace udvr::cmd {
namespace {

double secondsSince(std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

std::string shortNumber(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", v);
    return buf;
}

/// Fit the options to n samples per voxel (the library's rule) and say what was fitted on
/// stderr (after the check, so an error stays the one line).
void fitOptionsToSamples(BuildOptions& opt, long long samples, bool gmmGiven, bool quantilesGiven) {
    const BuildFitNotes notes = fitBuildOptionsToSamples(opt, samples, gmmGiven, quantilesGiven);
    for (const std::string& w : notes.warnings)
        std::fprintf(stderr, "udvr: warning: %s\n", w.c_str());
    if (!notes.info.empty())
        std::fprintf(stderr, "build: %d samples per voxel: %s\n",
                     static_cast<int>(std::min<long long>(samples, 1 << 30)), notes.info.c_str());
}

}  // namespace

void addBuildCommand(CLI::App& app) {
    auto* sub = app.add_subcommand(
        "build",
        "per-voxel distribution models (moments, quantiles, IQR, GMM) from an ensemble "
        "or from K^3 bricks of one field, written as a .vti model");
    struct Opts {
        std::vector<std::string> inputs;
        std::string out, density, bandwidth = "silverman", var, memberDim, levels, nan = "error";
        int quantiles = 8, gmm = 4, downsample = 0;
        double tailEps = 0.0;
        CLI::Option* downsampleOpt = nullptr;
        CLI::Option* tailEpsOpt = nullptr;
        CLI::Option* gmmOpt = nullptr;
        CLI::Option* quantilesOpt = nullptr;
        RawLayoutFlags raw;  // headerless .raw inputs
    };
    auto o = std::make_shared<Opts>();
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
    sub->add_option("-o,--output", o->out, "output model .vti")->required();
    addRawLayoutOptions(sub, o->raw);

    sub->callback([o] {
        requireOutputExtension(o->out, "-o", {".vti"}, "build writes a model as VTK ImageData");
        BuildOptions opt;
        opt.quantiles = o->quantiles;
        if (!o->levels.empty()) {
            opt.quantileLevels = parseDoubleList(o->levels, "--quantile-levels");
            const int q = static_cast<int>(opt.quantileLevels.size()) - 1;
            if (o->quantilesOpt->count() > 0 && o->quantiles != q)
                UDVR_FAIL("--quantiles " << o->quantiles << " disagrees with the " << q + 1
                                         << " values of --quantile-levels (q + 1 boundaries)");
            opt.quantiles = q;
        }
        opt.gmmComponents = o->gmm;
        opt.nan = parseNanPolicy(o->nan);
        const bool skipNan = opt.nan == NanPolicy::Skip;
        const bool bricks = o->downsampleOpt->count() > 0;
        opt.density =
            o->density.empty() ? defaultDensity(bricks) : parseDensityEstimate(o->density);
        opt.bandwidthText = o->bandwidth;
        if (opt.density == DensityEstimate::Kde) opt.bandwidth = parseBandwidth(o->bandwidth);
        if (o->tailEpsOpt->count() > 0) {
            if (!(o->tailEps > 0.0))
                UDVR_FAIL("--tail-eps " << o->tailEps << " is out of range; expected 0 < E < 0.5");
            opt.tailEps = o->tailEps;
        }
        // What does not depend on the input is checked before it is read (the sample count
        // is then assumed large enough; fitOptionsToSamples checks against the real one).
        validateBuildOptions(opt, std::numeric_limits<int>::max());
        for (const std::string& in : o->inputs) opt.source += (opt.source.empty() ? "" : " ") + in;
        if (bricks) opt.source += " --downsample " + std::to_string(o->downsample);

        requireOutputDirectory(o->out, "-o");
        auto t0 = std::chrono::steady_clock::now();
        ModelVolume model;
        BuildReport rep;
        std::string what;
        double readSeconds = 0.0;
        if (bricks) {
            if (o->inputs.size() != 1)
                UDVR_FAIL("--downsample takes one field, got " << o->inputs.size() << " inputs");
            FieldReadOptions ro;
            ro.var = o->var;
            ro.raw = toRawLayout(o->raw);
            ro.allowMissing = skipNan;  // build's own scan reports them by policy
            ScalarField f;
            try {
                f = readField(o->inputs[0], ro);
            } catch (const EnsembleNotFieldError& e) {
                UDVR_FAIL(e.file << " holds a " << e.members << "-member ensemble (variable '"
                                 << e.var << "', dims " << e.dims
                                 << "): --downsample reduces one field; drop --downsample to "
                                    "build the model from the "
                                 << e.members << " members");
            }
            readSeconds = secondsSince(t0);
            checkDensityForInput(opt.density, f.valueStep, f.valueType);
            const Grid3 reduced = downsampledGrid(f.grid, o->downsample);
            const long long k = o->downsample;
            fitOptionsToSamples(opt, k * k * k, o->gmmOpt->count() > 0,
                                o->quantilesOpt->count() > 0);
            ProgressBar bar("build", reduced.pointCount());
            opt.progress = &bar;
            model = buildModelDownsampled(f, o->downsample, opt, &rep);
            bar.finish();
            if (rep.droppedPlanes != std::array<int, 3>{0, 0, 0})
                std::fprintf(stderr,
                             "build: %dx%dx%d is not a multiple of %d; left out the trailing "
                             "%d,%d,%d planes in x,y,z\n",
                             f.grid.dims[0], f.grid.dims[1], f.grid.dims[2], o->downsample,
                             rep.droppedPlanes[0], rep.droppedPlanes[1], rep.droppedPlanes[2]);
            what = std::to_string(f.grid.dims[0]) + "x" + std::to_string(f.grid.dims[1]) + "x" +
                   std::to_string(f.grid.dims[2]) + " field in " + std::to_string(o->downsample) +
                   "^3 bricks";
        } else {
            const std::string& first = o->inputs[0];
            if (o->inputs.size() == 1 && first.find_first_of("*?[") == std::string::npos &&
                lowerExtension(first) != ".nc")
                UDVR_FAIL(first << " is one field: --downsample K models its K^3 bricks; an "
                                   "ensemble is a NetCDF variable with a member dimension or 2+ "
                                   "member files");
            EnsembleReadOptions ro;
            ro.var = o->var;
            ro.memberDim = o->memberDim;
            ro.raw = toRawLayout(o->raw);
            ro.allowMissing = skipNan;
            const Ensemble e = readEnsemble(o->inputs, ro);
            readSeconds = secondsSince(t0);
            checkDensityForInput(opt.density, e.valueStep, e.valueType);
            // Checks the options before the bar is drawn.
            fitOptionsToSamples(opt, e.members, o->gmmOpt->count() > 0,
                                o->quantilesOpt->count() > 0);
            ProgressBar bar("build", e.grid.pointCount());
            opt.progress = &bar;
            model = buildModel(e, opt, &rep);
            bar.finish();
            what = std::to_string(e.members) + "-member ensemble";
        }
        auto t1 = std::chrono::steady_clock::now();
        writeModelVti(o->out, model);
        const double writeSeconds = secondsSince(t1);

        const auto& d = model.grid.dims;
        std::fprintf(
            stderr,
            "build: %s -> %dx%dx%d voxels x %d samples; q=%d (%s%s%s), GMM K=%d; "
            "%d threads\n",
            what.c_str(), d[0], d[1], d[2], rep.samplesPerVoxel, opt.quantiles,
            model.quantileLevels.empty() ? "" : "uneven levels, ", model.density.c_str(),
            opt.density == DensityEstimate::Kde
                ? (", h " + model.bandwidthRule + " median " + std::to_string(model.bandwidth))
                      .c_str()
            : opt.density == DensityEstimate::Dequantized
                ? (", step " + shortNumber(model.bandwidth)).c_str()
                : "",
            opt.gmmComponents, threadCount());
        if (opt.gmmComponents > 0)
            std::fprintf(stderr,
                         "build: EM %.1f iterations per voxel on average, %zu voxels stopped at "
                         "100; %zu constant voxels, %zu with fewer distinct values than K\n",
                         rep.meanGmmIterations, rep.gmmNotConverged, rep.constantVoxels,
                         rep.gmmFewerDistinct);
        if (rep.nonFiniteSamples > 0)
            std::fprintf(stderr,
                         "build: --nan skip: left out %zu NaN/Inf samples at %zu voxels (the "
                         "fewest finite samples at a voxel: %d of %d)\n",
                         rep.nonFiniteSamples, rep.voxelsWithNonFinite, rep.fewestFiniteSamples,
                         rep.samplesPerVoxel);
        // Wall times of the three phases; the statistics' stages as CPU time over all threads.
        std::fprintf(stderr,
                     "build: read %.2f s, statistics %.2f s (CPU: scan %.2f, gather %.2f, "
                     "sort+moments+quantiles %.2f, GMM %.2f s), write %.2f s -> %s\n",
                     readSeconds, rep.seconds, rep.scanCpu, rep.gatherCpu, rep.estimateCpu,
                     rep.gmmCpu, writeSeconds, o->out.c_str());
    });
}

}  // namespace udvr::cmd
