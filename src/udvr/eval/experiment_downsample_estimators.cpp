// udvr experiment downsample-estimators (issue 12.2): which estimate of the quantile boundaries
// serves volumes reduced by 4³ bricks. Such bricks hold many equal values (0 between the nested
// spheres, 8-bit CT values), so empirical quantiles get zero widths and quantile-mean's density
// weights 1/w_j (Athawale et al. 2021, Eq. 5) put all the weight on the ties; the paper built
// its quantiles from a KDE. Per volume: empirical quantiles, KDE quantiles with each bandwidth
// rule and, for integer-typed inputs, the dequantised estimate, each rendered as quantile-range
// (Eq. 4), quantile-mean (Eq. 5) and iqr; the estimator-free models once for reference. RMSE
// against the full-resolution field, as the `spheres` and `chest` experiments.
#include <algorithm>
#include <limits>
#include <optional>

#include "udvr/data/synthetic.h"
#include "udvr/eval/experiment_run.h"
#include "udvr/io/field_io.h"

namespace udvr::experiment_detail {
namespace {

constexpr int kBrick = 4;
constexpr int kQuantiles = 8;

struct Estimator {
    const char* name;  // the table's density column
    DensityEstimate density;
    const char* bandwidth;  // kde rule
};

const std::vector<Estimator>& estimators() {
    static const std::vector<Estimator> e = {
        {"empirical", DensityEstimate::Empirical, ""},
        {"kde-silverman", DensityEstimate::Kde, "silverman"},
        {"kde-scott", DensityEstimate::Kde, "scott"},
        {"dequantized", DensityEstimate::Dequantized, ""},
    };
    return e;
}

/// The models whose image depends on the estimator (they read the boundaries), with their
/// caption in the panel (null: in the table only).
struct EstimatorModel {
    ModelKind kind;
    const char* caption;
};
constexpr EstimatorModel kQuantileModels[] = {
    {ModelKind::QuantileRange, "QR"}, {ModelKind::QuantileMean, "QM"}, {ModelKind::Iqr, nullptr}};
/// The panel's columns after the truth: each estimator under these captions, in this order.
constexpr const char* kPanelCaptions[] = {"QM", "QR"};
/// The estimator-free models, rendered once per volume for reference (gmm-mc, 200
/// realizations, is in `spheres` and `chest`; `uniform` is the fast box spline, within 5e−4 of
/// `uniform-exact`).
constexpr ModelKind kReferenceModels[] = {ModelKind::Mean, ModelKind::Gaussian, ModelKind::Uniform,
                                          ModelKind::GmmOrdered};

/// One volume of the study: where it comes from and how it is seen.
struct Volume {
    std::string name;
    std::string tfFile;
    std::string description;  // a setup line
    std::string absentPath;   // non-empty: the shared data file is missing
    std::function<ScalarField()> load;
    std::function<Camera(const std::array<double, 6>&)> camera;  // null: the default view
};

std::vector<Volume> volumes(const ExperimentOptions& options, int sphereDims) {
    std::vector<Volume> v;
    v.push_back({"spheres", "spheres.json",
                 "spheres: nested spheres (`udvr generate spheres`, shells 25, 50, 75, 100, 0 "
                 "between; float32) on " +
                     std::to_string(sphereDims) + "³ grid points",
                 "", [sphereDims] { return makeNestedSpheres(sphereDims, sphereDims, sphereDims); },
                 nullptr});
    struct Shared {
        const char *name, *file, *tf, *what;
    };
    const Shared shared[] = {
        {"chest", "chest-ct/chest.nhdr", "chest-ct.json",
         "chest: the chest CT (uint8, 256×256×133), seen from the front as in `chest`"},
        {"neghip", "neghip/neghip.nhdr", "neghip.json",
         "neghip: the negative potential of a high-potential iron protein (uint8, 64³)"},
        {"tooth", "tooth/tooth.nhdr", "tooth.json",
         "tooth: the tooth CT (uint8, 103×94×161), seen from the side as in `tooth2d`"},
    };
    for (const Shared& s : shared) {
        const fs::path path = sharedDataPath(options, s.file);
        Volume vol{s.name,
                   s.tf,
                   std::string(s.what) + " (`" + path.string() + "`)",
                   "",
                   [path] { return readField(path); },
                   nullptr};
        if (path.empty() || !fs::exists(path))
            vol.absentPath = path.empty() ? std::string("<shared data>/") + s.file : path.string();
        if (vol.name == "chest") vol.camera = chestCamera;
        if (vol.name == "tooth")
            vol.camera = [](const std::array<double, 6>& b) {
                return sideCamera(b, 35.0, 10.0, 1.15);
            };
        v.push_back(std::move(vol));
    }
    return v;
}

/// RMSE of one (volume, model, estimator); NaN where the estimator does not apply.
using RmseTable = std::map<std::string, std::map<std::string, std::map<std::string, double>>>;

/// A policy for the default: the estimator for integer-typed inputs and the one for floats.
struct Policy {
    std::string integer, floating;
    std::string name() const { return integer == floating ? integer : integer + " / " + floating; }
};

/// Relative regret of an estimator on one (volume, model): RMSE over the best of any estimator
/// there, minus 1.
double regret(const std::map<std::string, double>& byEstimator, const std::string& e) {
    double best = std::numeric_limits<double>::infinity();
    for (const auto& [name, r] : byEstimator)
        if (std::isfinite(r)) best = std::min(best, r);
    return byEstimator.at(e) / best - 1.0;
}

std::string pct(double r) { return fmt("%.1f", 100.0 * r) + " %"; }

}  // namespace

ExperimentResult runDownsampleEstimators(const fs::path& dir, const ExperimentOptions& options) {
    Run run("downsample-estimators", dir, options, resolveSizes("downsample-estimators", options));
    const Sizes& s = run.sizes();
    const int sphereDims = std::max(s.dims, 2 * kBrick);
    std::vector<std::string> setup;
    RmseTable rmse;                            // volume → model → estimator → RMSE
    std::map<std::string, bool> integerInput;  // volume → integer-typed
    std::vector<std::string> measured;         // volumes in order
    const std::size_t columns = 1 + 2 * estimators().size();

    for (const Volume& vol : volumes(options, sphereDims)) {
        if (!vol.absentPath.empty()) {
            setup.push_back(vol.name + ": not run (no data at " + vol.absentPath + ").");
            continue;
        }
        ScalarField field = vol.load();
        run.log("loaded " + vol.name + " (" + std::to_string(field.grid.dims[0]) + "×" +
                std::to_string(field.grid.dims[1]) + "×" + std::to_string(field.grid.dims[2]) +
                ", " + (field.valueType.empty() ? "float32" : field.valueType) + ")");
        const Grid3 reducedGrid = downsampledGrid(field.grid, kBrick);
        setup.push_back(vol.description + ", reduced by " + std::to_string(kBrick) +
                        "³ bricks to " + std::to_string(reducedGrid.dims[0]) + "×" +
                        std::to_string(reducedGrid.dims[1]) + "×" +
                        std::to_string(reducedGrid.dims[2]) + "; TF `data/tf/" + vol.tfFile + "`.");
        measured.push_back(vol.name);
        integerInput[vol.name] = field.valueStep > 0.0;
        run.loadTf(vol.tfFile);
        const std::size_t firstItem = run.items().size();
        {
            // The full-resolution truth, without the σ it does not render with.
            ModelVolume truth = modelFromField(field);
            truth.stddev = {};
            run.setView(truth.bounds);
            if (vol.camera) run.setCamera(vol.camera(truth.bounds));
            run.renderTruth(truth, 1, kBrick * kBrick * kBrick);
        }
        run.result().rows.back().label = vol.name + ": ground truth";
        run.items().back().caption[0] = vol.name + ": ground truth";

        const int samples = kBrick * kBrick * kBrick;
        // caption → estimator → index in items()
        std::map<std::string, std::map<std::string, std::size_t>> panelItem;
        for (const Estimator& est : estimators()) {
            for (const auto& [k, caption] : kQuantileModels)
                rmse[vol.name][std::string(modelName(k))][est.name] =
                    std::numeric_limits<double>::quiet_NaN();
            if (est.density == DensityEstimate::Dequantized && field.valueStep <= 0.0) continue;
            BuildOptions bo;
            bo.quantiles = kQuantiles;
            bo.gmmComponents = est.density == DensityEstimate::Empirical ? 4 : 0;
            bo.density = est.density;
            if (est.density == DensityEstimate::Kde) {
                bo.bandwidth = parseBandwidth(est.bandwidth);
                bo.bandwidthText = est.bandwidth;
            }
            bo.source = "downsample-estimators " + vol.name + " " + est.name;
            BuildReport rep;
            std::optional<StageScope> stage(
                std::in_place, buildWork(double(reducedGrid.pointCount()), kBrick * kBrick * kBrick,
                                         bo.gmmComponents, bo.density, true));
            const ModelVolume model = buildModelDownsampled(field, kBrick, bo, &rep);
            stage.reset();
            run.log("built " + vol.name + " with " + est.name + " quantiles in " +
                    fmt("%.2f", rep.seconds) + " s");
            if (est.density == DensityEstimate::Empirical)
                for (ModelKind k : kReferenceModels) {
                    const ResultRow row =
                        run.add(model, k, samples, " (" + vol.name + ")", false, false);
                    rmse[vol.name][row.model]["-"] = row.rmse;
                }
            for (const EstimatorModel& m : kQuantileModels) {
                const bool panel = m.caption != nullptr;
                const ResultRow row = run.add(
                    model, m.kind, samples, " (" + vol.name + ", " + est.name + ")", panel, panel);
                run.result().rows.back().density = est.name;
                rmse[vol.name][row.model][est.name] = row.rmse;
                if (!panel) continue;
                panelItem[m.caption][est.name] = run.items().size() - 1;
                run.items().back().caption[0] = std::string(m.caption) + ", " + est.name;
            }
        }
        // The field is no longer needed; free it before the next volume is loaded.
        field = ScalarField{};

        // Difference images on this volume's own scale, against its truth.
        const double scale = run.writeDifferenceImages();
        setup.push_back(vol.name + ": difference images from blue (0) to yellow (" +
                        fmt("%.3f", scale) + ", the largest difference of its images).");
        // The panel row: truth, QM for each estimator, then QR for each (blank where none).
        std::vector<PanelItem>& items = run.items();
        std::vector<PanelItem> row;
        row.push_back(std::move(items[firstItem]));
        for (const char* caption : kPanelCaptions) {
            const std::map<std::string, std::size_t>& which = panelItem[caption];
            for (const Estimator& est : estimators()) {
                const auto it = which.find(est.name);
                row.push_back(it == which.end() ? PanelItem{} : std::move(items[it->second]));
            }
        }
        UDVR_CHECK(row.size() == columns);
        items.resize(firstItem);
        for (PanelItem& item : row) {
            item.diffFile.clear();  // written: the next volume's truth must not redo it
            items.push_back(std::move(item));
        }
    }

    // The rule: each policy (an estimator for integer-typed inputs, one for floats) is charged,
    // on every (volume, quantile model), its relative regret against the best estimator there;
    // the default is the policy whose worst regret is smallest (minimax regret).
    std::vector<Policy> policies;
    for (const Estimator& i : estimators())
        for (const Estimator& f : estimators())
            if (f.density != DensityEstimate::Dequantized &&
                (i.name == f.name || i.density == DensityEstimate::Dequantized))
                policies.push_back({i.name, f.name});
    std::string section;
    section += "RMSE against the full-resolution truth; the best estimator of each row in bold, ";
    section += "`—` where an estimator does not apply (dequantized needs integer-typed input).\n\n";
    section += "| volume | model |";
    for (const Estimator& e : estimators()) section += " " + std::string(e.name) + " |";
    section += "\n|---|---|";
    for (std::size_t i = 0; i < estimators().size(); ++i) section += "---:|";
    section += "\n";
    for (const std::string& v : measured)
        for (const auto& [k, caption] : kQuantileModels) {
            const auto& byEst = rmse[v][std::string(modelName(k))];
            section += "| " + v + " | " + std::string(modelName(k)) + " |";
            for (const Estimator& e : estimators()) {
                const double r = byEst.at(e.name);
                const bool best = std::isfinite(r) && regret(byEst, e.name) == 0.0;
                section += std::isfinite(r) ? (best ? " **" + fmt("%.5f", r) + "** |"
                                                    : " " + fmt("%.5f", r) + " |")
                                            : " — |";
            }
            section += "\n";
        }
    section += "\nThe estimator-free models on the same volumes:";
    for (const std::string& v : measured) {
        section += " " + v + ":";
        for (ModelKind k : kReferenceModels)
            section += " " + std::string(modelName(k)) + " " +
                       fmt("%.5f", rmse[v][std::string(modelName(k))]["-"]) +
                       (k == kReferenceModels[3] ? ";" : ",");
    }
    section +=
        "\n\n**Rule** (minimax regret): a policy picks an estimator for integer-typed "
        "inputs and one for float inputs; on each volume and quantile model its regret is "
        "its RMSE over the best estimator's there, minus 1; the default is the policy "
        "whose largest regret over all volumes and the three quantile models is smallest.\n\n"
        "| policy (integer / float inputs) | largest regret | where | mean regret |\n"
        "|---|---:|---|---:|\n";
    std::string chosen;
    double chosenWorst = std::numeric_limits<double>::infinity();
    for (const Policy& p : policies) {
        double worst = -1.0, sum = 0.0;
        int count = 0;
        std::string where;
        for (const std::string& v : measured)
            for (const auto& [k, caption] : kQuantileModels) {
                const auto& byEst = rmse[v][std::string(modelName(k))];
                const double r = regret(byEst, integerInput[v] ? p.integer : p.floating);
                sum += r;
                ++count;
                if (r > worst) worst = r, where = v + " " + std::string(modelName(k));
            }
        if (count == 0) continue;
        section += "| " + p.name() + " | " + pct(worst) + " | " + where + " | " + pct(sum / count) +
                   " |\n";
        if (worst < chosenWorst) chosenWorst = worst, chosen = p.name();
    }
    section += "\nBy this rule: **" + chosen + "** (largest regret " + pct(chosenWorst) + ").\n";
    run.addSection("Estimators and the default rule", section);
    run.writeFile("estimators.md", "# Quantile estimators for `--downsample`\n\n" + section);

    // The paper's claim per (volume, estimator): quantile-mean lowest of all models.
    for (const std::string& v : measured)
        for (const Estimator& e : estimators()) {
            const double qm = rmse[v]["quantile-mean"][e.name];
            if (!std::isfinite(qm)) continue;
            std::string lowest = "quantile-mean";
            double lowestRmse = qm;
            for (const auto& [model, byEst] : rmse[v]) {
                const auto it = byEst.find(byEst.count("-") ? "-" : e.name);
                if (it != byEst.end() && std::isfinite(it->second) && it->second < lowestRmse)
                    lowest = model, lowestRmse = it->second;
            }
            ClaimCheck c;
            c.claim = v + ", " + e.name +
                      " quantiles: quantile-mean has the lowest RMSE of the models (Figs. 8, 9)";
            c.verdict = lowest == "quantile-mean" ? "holds" : "does not hold";
            c.detail =
                "quantile-mean " + fmt("%.5f", qm) +
                (lowest == "quantile-mean" ? ""
                                           : "; lowest " + lowest + " " + fmt("%.5f", lowestRmse));
            run.addClaim(c);
        }

    setup.push_back("Every model from the same " + std::to_string(kBrick) + "³ bricks (" +
                    std::to_string(kBrick * kBrick * kBrick) +
                    " samples per voxel), q = " + std::to_string(kQuantiles) +
                    " even levels. Estimators (SPEC §2, `build --density`): empirical (numpy's "
                    "linear sample quantiles), kde-silverman and kde-scott (Gaussian KDE, tails "
                    "at ε = 1/(2n)), dequantized (integer inputs: each value v spread uniformly "
                    "over [v − ½, v + ½] before the quantiles, exactly).");
    setup.push_back(
        "quantile-range, quantile-mean and iqr are rendered for each estimator; mean, gaussian, "
        "uniform (the fast box spline) and gmm-ordered (GMM K = 4) do not depend on it and are "
        "rendered once.");
    setup.push_back(
        "Each volume in its own view (spheres and neghip: the default camera) with its own TF; "
        "the camera and TF lines below are the last volume's.");
    setup.push_back(
        "Figure: one row per volume — the truth, quantile-mean (QM) with each estimator, then "
        "quantile-range (QR) with each — and the difference images under it.");
    const std::string title =
        "Quantile estimators for volumes reduced by 4³ bricks: empirical, KDE (Silverman, Scott), "
        "dequantized";
    run.writeFigure("figure.png",
                    renderPanel(makePanel(title, run.items(), static_cast<int>(columns))));
    return run.finish(title, setup, {"figure.png"});
}

}  // namespace udvr::experiment_detail
