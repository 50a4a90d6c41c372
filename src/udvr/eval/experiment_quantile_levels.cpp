// udvr experiment quantile-levels (issue 12.3; Athawale et al. 2021 §6 names uneven quantiles as
// future work): at equal memory (q = 8, nine boundaries per voxel) even levels against
// tail-heavy and centre-heavy ones, for quantile-range (Eq. 4) and quantile-mean (Eq. 5), on the
// tangle ensemble and on volumes reduced by 4³ bricks (nested spheres, the chest CT when the
// shared data is present). Every model's RMSE is against its dataset's full-resolution truth.
#include <algorithm>
#include <limits>
#include <memory>

#include "udvr/data/noise.h"
#include "udvr/data/synthetic.h"
#include "udvr/eval/experiment_run.h"
#include "udvr/io/field_io.h"

namespace udvr::experiment_detail {
namespace {

struct LevelSet {
    const char* name;
    std::vector<double> levels;  // t_0 = 0 … t_8 = 1
};

/// The three level sets compared, each with q = 8.
const std::vector<LevelSet>& levelSets() {
    static const std::vector<LevelSet> sets = {
        {"even", {0, .125, .25, .375, .5, .625, .75, .875, 1}},
        {"tail-heavy", {0, .02, .1, .25, .5, .75, .9, .98, 1}},
        {"centre-heavy", {0, .25, .4, .45, .5, .55, .6, .75, 1}},
    };
    return sets;
}

std::string levelsText(const std::vector<double>& t) {
    std::string s;
    for (double v : t) s += (s.empty() ? "" : ", ") + fmt("%g", v);
    return s;
}

/// One dataset: its truth and how its model is built for a level set.
struct Dataset {
    std::string name;
    std::string tfFile;
    ModelVolume truth;
    int samples = 0;  // per voxel of the models
    std::function<ModelVolume(const BuildOptions&)> build;
    std::shared_ptr<const Ensemble> ensemble;  // for the members image; null for bricks
};

}  // namespace

ExperimentResult runQuantileLevels(const fs::path& dir, const ExperimentOptions& options) {
    Run run("quantile-levels", dir, options, resolveSizes("quantile-levels", options));
    const Sizes& s = run.sizes();
    constexpr int kBrick = 4;
    std::vector<std::string> setup;
    std::vector<Dataset> datasets;
    {
        const ScalarField tangle = makeTangle(s.dims, s.dims, s.dims);
        NoiseParams noise;
        noise.seed = kNoiseSeed;
        auto ensemble = std::make_shared<Ensemble>(perturbField(tangle, s.members, noise));
        datasets.push_back({"tangle", "tangle.json", modelFromField(tangle), s.members,
                            [ensemble](const BuildOptions& o) { return buildModel(*ensemble, o); },
                            ensemble});
        setup.push_back("tangle: " + std::to_string(s.dims) + "³, " + std::to_string(s.members) +
                        " members with the paper's bimodal noise (seed " +
                        std::to_string(kNoiseSeed) + "), TF `data/tf/tangle.json`.");
    }
    const int sphereDims = options.dims > 0 ? std::max(options.dims, 2 * kBrick)
                           : options.quick  ? 64
                                            : 256;
    auto spheres =
        std::make_shared<ScalarField>(makeNestedSpheres(sphereDims, sphereDims, sphereDims));
    datasets.push_back(
        {"spheres", "spheres.json", modelFromField(*spheres), kBrick * kBrick * kBrick,
         [spheres](const BuildOptions& o) { return buildModelDownsampled(*spheres, kBrick, o); },
         nullptr});
    setup.push_back("spheres: nested spheres " + std::to_string(sphereDims) + "³ reduced by " +
                    std::to_string(kBrick) + "³ bricks, TF `data/tf/spheres.json`.");
    const fs::path chest = sharedDataPath(options, "chest-ct/chest.nhdr");
    if (!chest.empty() && fs::exists(chest)) {
        auto field = std::make_shared<ScalarField>(readField(chest));
        datasets.push_back(
            {"chest", "chest-ct.json", modelFromField(*field), kBrick * kBrick * kBrick,
             [field](const BuildOptions& o) { return buildModelDownsampled(*field, kBrick, o); },
             nullptr});
        setup.push_back("chest: the chest CT `" + chest.string() + "` reduced by " +
                        std::to_string(kBrick) + "³ bricks, TF `data/tf/chest-ct.json`.");
    } else {
        setup.push_back("chest: not run (no chest CT in the shared data).");
    }
    for (const LevelSet& ls : levelSets())
        setup.push_back("Levels " + std::string(ls.name) + ": " + levelsText(ls.levels) + ".");
    setup.push_back(
        "Equal memory: every model stores q + 1 = 9 boundaries per voxel (empirical quantiles, "
        "no GMM); RMSE against each dataset's full-resolution ground truth.");
    setup.push_back(
        "Ensembles (the tangle) also render the members image (`--model members`: the TF "
        "averaged over the members at each sample), and each row's RMSE against it.");
    setup.push_back(
        "Each dataset in its own default view (azimuth 30°, elevation 20°, framing its box); the "
        "camera and TF lines below are the last dataset's.");

    // The models compared, with their short caption in the panel.
    const std::pair<ModelKind, const char*> kinds[] = {{ModelKind::QuantileRange, "QR"},
                                                       {ModelKind::QuantileMean, "QM"}};
    for (Dataset& d : datasets) {
        run.loadTf(d.tfFile);
        run.setView(d.truth.bounds);
        run.renderTruth(d.truth, 1, 1.0);
        run.result().rows.back().label = d.name + ": ground truth";
        run.items().back().caption[0] = d.name + ": ground truth";
        // The model's voxels: the ensemble's grid, or the field's reduced by the bricks.
        const double voxels =
            double(d.ensemble ? d.truth.grid.pointCount()
                              : downsampledGrid(d.truth.grid, kBrick).pointCount());
        d.truth = {};      // the rendered truth is all that is needed from here on
        if (d.ensemble) {  // the ensemble's own expected image: rows get their RMSE against it
            run.addMembers(*d.ensemble, " (" + d.name + ")", true, false);
            run.items().back().caption[0] = d.name + ": members";
        } else {
            run.addPanelItem({});  // a blank cell, so every dataset's row lines up
        }
        std::map<std::string, double> rmse;  // "<kind> <levels>"
        for (const LevelSet& ls : levelSets()) {
            BuildOptions bo;
            bo.quantiles = 8;
            bo.quantileLevels = ls.levels;
            bo.gmmComponents = 0;
            bo.source = "quantile-levels " + d.name + " " + ls.name;
            std::optional<StageScope> stage(
                std::in_place, buildWork(voxels, d.samples, 0, bo.density, !d.ensemble));
            const ModelVolume model = d.build(bo);
            stage.reset();
            run.log("built " + d.name + " with " + ls.name + " levels");
            for (const auto& [k, caption] : kinds) {
                const ResultRow row =
                    run.add(model, k, d.samples, " " + std::string(ls.name) + " (" + d.name + ")",
                            true, false);
                rmse[std::string(modelName(k)) + " " + ls.name] = row.rmse;
                // A short caption for the panel (the table keeps the full label).
                run.items().back().caption[0] = std::string(caption) + ", " + ls.name;
            }
        }
        // Which level set wins, per model.
        for (const auto& [k, caption] : kinds) {
            const std::string kind(modelName(k));
            std::string best, detail;
            double bestRmse = std::numeric_limits<double>::infinity();
            for (const LevelSet& ls : levelSets()) {
                const double e = rmse[kind + " " + ls.name];
                detail +=
                    (detail.empty() ? "" : ", ") + std::string(ls.name) + " " + fmt("%.5f", e);
                if (e < bestRmse) bestRmse = e, best = ls.name;
            }
            const double even = rmse[kind + " even"];
            ClaimCheck c;
            c.claim = d.name + ", " + kind + ": uneven levels beat even ones at equal memory";
            c.verdict = best == "even" ? "does not hold" : "holds";
            c.detail = "RMSE " + detail + "; best " + best + " (" +
                       fmt("%+.1f", 100.0 * (bestRmse - even) / even) + " % against even)";
            run.addClaim(c);
        }
    }
    const std::string title =
        "Uneven quantile levels at equal memory (q = 8): QR = quantile-range, QM = quantile-mean";
    run.writeFigure("figure.png", renderPanel(makePanel(title, run.items(), 8)));
    return run.finish(title, setup, {"figure.png"});
}

}  // namespace udvr::experiment_detail
