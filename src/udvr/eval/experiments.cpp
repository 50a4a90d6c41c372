#include "udvr/eval/experiments.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>

#include "udvr/classify/model_families.h"
#include "udvr/data/noise.h"
#include "udvr/data/synthetic.h"
#include "udvr/eval/experiment_plan.h"
#include "udvr/eval/experiment_run.h"
#include "udvr/eval/figure.h"
#include "udvr/eval/image_metrics.h"
#include "udvr/eval/report.h"
#include "udvr/io/field_io.h"
#include "udvr/io/image.h"
#include "udvr/io/output_path.h"
#include "udvr/io/transfer_function_io.h"
#include "udvr/render/render.h"
#include "udvr/stats/build_model.h"
#include "udvr/util/atomic_file.h"
#include "udvr/util/check.h"
#include "udvr/util/text_parse.h"

namespace udvr {
namespace fs = std::filesystem;
namespace {

using namespace experiment_detail;

/// The paper's bimodal noise (noise.h defaults), its magnitudes scaled by `scale`.
NoiseParams noiseParams(double scale) {
    NoiseParams p;
    p.seed = kNoiseSeed;
    p.sigma *= scale;
    p.outlierOffset *= scale;
    p.outlierSigma *= scale;
    return p;
}

std::string noiseLine(int members, double scale = 1.0) {
    const NoiseParams p = noiseParams(scale);
    return std::to_string(members) + " members = truth + bimodal noise (seed " +
           std::to_string(kNoiseSeed) + "): 80 % N(0, (" + fmt("%g", p.sigma) +
           "R)²), 20 % outliers N(+" + fmt("%g", p.outlierOffset) + "R, (" +
           fmt("%g", p.outlierSigma) + "R)²), R the field's value range (Athawale et al. 2021 §5).";
}

/// Render the deterministic field as the ground truth and aim the camera at it.
void renderTruthOf(Run& run, const ScalarField& truthField, double zoom = 1.0) {
    const ModelVolume truthModel = modelFromField(truthField);
    run.setView(truthModel.bounds, kAzimuth, kElevation, zoom);
    run.renderTruth(truthModel, 1, 1.0);
}

/// What the members image is, for the setup lists of the ensemble experiments.
constexpr const char* kMembersLine =
    "members = the ensemble's own expected image, no model: the TF averaged over the members at "
    "each sample (each member interpolated trilinearly), composited as any model; the table's "
    "rmse_members compares every later image with it.";

Ensemble makeEnsemble(const ScalarField& truth, int members, double scale = 1.0) {
    return perturbField(truth, members, noiseParams(scale));
}

// ---- tangle (Fig. 4) and teardrop (teaser a) -------------------------------------------------

ExperimentResult runEnsembleExperiment(const std::string& name, const fs::path& dir,
                                       const ExperimentOptions& options) {
    const bool tangle = name == "tangle";
    Run run(name, dir, options, resolveSizes(name, options));
    const Sizes& s = run.sizes();
    run.loadTf(tangle ? "tangle.json" : "teardrop.json");
    const ScalarField truthField = makeSyntheticField(name, s.dims, s.dims, s.dims);
    run.log("generated " + name + " " + std::to_string(s.dims) + "³");
    // The teardrop's value range R is set by the box corners (≈ −79), twenty times the drop's
    // own values (0 … 4.1): the tangle's noise fractions would bury the drop, so a quarter.
    const double noiseScale = tangle ? 1.0 : kTeardropNoiseScale;
    const Ensemble ensemble = makeEnsemble(truthField, s.members, noiseScale);
    run.log("perturbed: " + std::to_string(s.members) + " members, bimodal noise");
    // The drop (x ∈ [−1, 0], radius ≤ 0.2) fills little of its box: come closer.
    renderTruthOf(run, truthField, tangle ? 1.0 : 1.6);

    // The ensemble's own expected image first: every model is compared with it too.
    run.addMembers(ensemble);
    // One build with q = 8 and the GMM serves every model but the smaller q's.
    const ModelVolume m8 = run.build(ensemble, 8, 4, DensityEstimate::Empirical);
    for (ModelKind k : {ModelKind::Mean, ModelKind::Uniform, ModelKind::Gaussian, ModelKind::GmmMc,
                        ModelKind::GmmOrdered})
        run.add(m8, k, s.members);
    run.addPanelItem(tfItem(run.tf(), std::min(kThumbMax, s.image)));
    if (tangle) {
        const ModelVolume m2 = run.build(ensemble, 2, 0, DensityEstimate::Empirical);
        const ModelVolume m4 = run.build(ensemble, 4, 0, DensityEstimate::Empirical);
        for (ModelKind k : {ModelKind::QuantileRange, ModelKind::QuantileMean}) {
            run.add(m2, k, s.members);
            run.add(m4, k, s.members);
            run.add(m8, k, s.members);
        }
    } else {
        run.add(m8, ModelKind::QuantileRange, s.members);
        run.add(m8, ModelKind::QuantileMean, s.members);
    }
    run.add(m8, ModelKind::Iqr, s.members);

    const std::string title =
        tangle ? "Tangle " + std::to_string(s.dims) + "³, " + std::to_string(s.members) +
                     " members, bimodal noise (Athawale et al. 2021, Fig. 4)"
               : "Teardrop " + std::to_string(s.dims) + "³, " + std::to_string(s.members) +
                     " members, bimodal noise (Athawale et al. 2021, teaser a)";
    const double scale = run.writeDifferenceImages();
    run.writeFigure("figure.png", renderPanel(makePanel(title, run.items(), 8)));
    std::vector<std::string> setup = {
        std::string(tangle ? "Tangle" : "Teardrop") + " field on " + std::to_string(s.dims) +
            "³ grid points (`udvr generate " + name +
            "`); ground truth = the field rendered as a mean model.",
        noiseLine(s.members, noiseScale),
        "Models built with empirical quantiles (q = 8 and, for the tangle, 2 and 4), GMM K = 4 "
        "(EM); gmm-mc averages " +
            std::to_string(s.realizations) + " realizations.",
        kMembersLine,
        "Difference images: per-pixel |Δ mean RGB| against the ground truth, blue (0) to yellow (" +
            fmt("%.3f", scale) + ", the largest difference of any model)."};
    return run.finish(title, setup, {"figure.png"});
}

// ---- tangle-sweep (Fig. 5a) ------------------------------------------------------------------

ExperimentResult runSweep(const fs::path& dir, const ExperimentOptions& options) {
    Run run("tangle-sweep", dir, options, resolveSizes("tangle-sweep", options));
    const Sizes& s = run.sizes();
    run.loadTf("tangle.json");
    const ScalarField truthField = makeTangle(s.dims, s.dims, s.dims);
    renderTruthOf(run, truthField);
    const int maxMembers = *std::max_element(s.sweepMembers.begin(), s.sweepMembers.end());
    // Members are deterministic in (seed, member, voxel): the first m members of the largest
    // ensemble are the m-member ensemble, so the sets nest as the sample size grows.
    const Ensemble full = makeEnsemble(truthField, maxMembers);
    const std::vector<int> qs = {2, 4, 8};
    const std::vector<DensityEstimate> densities = {DensityEstimate::Empirical,
                                                    DensityEstimate::Kde};
    for (int m : s.sweepMembers) {
        Ensemble e;
        e.grid = full.grid;
        e.members = m;
        e.name = full.name;
        e.values.assign(full.values.begin(), full.values.begin() + static_cast<std::ptrdiff_t>(m) *
                                                                       static_cast<std::ptrdiff_t>(
                                                                           full.grid.pointCount()));
        const std::string suffix = ", " + std::to_string(m) + " members";
        run.addMembers(e, suffix, false, false);
        bool parametricDone = false;
        for (DensityEstimate d : densities)
            for (int q : qs) {
                const ModelVolume model = run.build(e, q, 0, d);
                if (!parametricDone) {
                    run.add(model, ModelKind::Mean, m, suffix, false, false);
                    run.add(model, ModelKind::Gaussian, m, suffix, false, false);
                    parametricDone = true;
                }
                const std::string ds = ", " + densityName(d) + suffix;
                run.add(model, ModelKind::QuantileRange, m, ds, false, false);
                run.add(model, ModelKind::QuantileMean, m, ds, false, false);
            }
    }
    // The plot: one set of axes per density, RMSE vs members, one line per (model, q).
    const std::array<std::array<double, 3>, 3> qColour = {
        {{0.85, 0.37, 0.01}, {0.11, 0.62, 0.47}, {0.46, 0.44, 0.70}}};
    std::vector<PlotAxes> axes;
    for (DensityEstimate d : densities) {
        PlotAxes ax;
        ax.title = "tangle " + std::to_string(s.dims) + "³: " + densityName(d) + " quantiles";
        ax.xLabel = "ensemble members";
        ax.yLabel = "RMSE";
        ax.logX = true;
        for (const char* model : {"quantile-range", "quantile-mean"})
            for (std::size_t qi = 0; qi < qs.size(); ++qi) {
                PlotSeries ser;
                ser.label = std::string(model == std::string("quantile-range") ? "QR" : "QM") +
                            " q=" + std::to_string(qs[qi]);
                ser.color = qColour[qi];
                ser.dashed = model == std::string("quantile-mean");
                for (int m : s.sweepMembers)
                    for (const ResultRow& r : run.result().rows)
                        if (r.model == model && r.quantiles == qs[qi] && r.members == m &&
                            r.density == densityName(d)) {
                            ser.x.push_back(m);
                            ser.y.push_back(r.rmse);
                        }
                ax.series.push_back(std::move(ser));
            }
        for (const char* model : {"mean", "gaussian", "members"}) {
            PlotSeries ser;
            ser.label = model;
            ser.color = model == std::string("mean")       ? std::array<double, 3>{0.2, 0.2, 0.2}
                        : model == std::string("gaussian") ? std::array<double, 3>{0.6, 0.6, 0.6}
                                                           : std::array<double, 3>{0.1, 0.4, 0.8};
            ser.dashed = model != std::string("members");
            for (int m : s.sweepMembers)
                for (const ResultRow& r : run.result().rows)
                    if (r.model == model && r.members == m) {
                        ser.x.push_back(m);
                        ser.y.push_back(r.rmse);
                    }
            ax.series.push_back(std::move(ser));
        }
        axes.push_back(std::move(ax));
    }
    run.writeFigure("figure.png", renderLinePlots(axes, 1100, 440));
    const std::string title =
        "Tangle sweep: RMSE vs quantiles × members (Athawale et al. 2021, Fig. 5a)";
    std::string memberList;
    for (int m : s.sweepMembers) memberList += (memberList.empty() ? "" : ", ") + std::to_string(m);
    std::vector<std::string> setup = {
        "Tangle on " + std::to_string(s.dims) + "³ grid points; members ∈ {" + memberList +
            "} (nested: the first m members of one seeded ensemble); bimodal noise as in `tangle`.",
        "q ∈ {2, 4, 8} for both density estimates of SPEC §2: empirical (numpy-linear sample "
        "quantiles) and KDE (Silverman's robust bandwidth, tails at ε = 1/(2n)).",
        "QR = quantile-range (Eq. 4, solid), QM = quantile-mean (Eq. 5, dashed); mean and "
        "gaussian for reference, and the members image (solid blue).",
        std::string(kMembersLine) + " Each member count has its own members image."};
    return run.finish(title, setup, {"figure.png"});
}

// ---- quartiles (Fig. 6) ----------------------------------------------------------------------

ExperimentResult runQuartiles(const fs::path& dir, const ExperimentOptions& options) {
    Run run("quartiles", dir, options, resolveSizes("quartiles", options));
    const Sizes& s = run.sizes();
    run.loadTf("tangle.json");
    const ScalarField truthField = makeTangle(s.dims, s.dims, s.dims);
    const Ensemble ensemble = makeEnsemble(truthField, s.members);
    renderTruthOf(run, truthField);
    run.addMembers(ensemble, "", false, false);
    const ModelVolume m8 = run.build(ensemble, 8, 0, DensityEstimate::Empirical);
    for (ModelKind k :
         {ModelKind::QuartileLower, ModelKind::QuartileMiddle, ModelKind::QuartileUpper})
        run.add(m8, k, s.members, "", true, false);
    run.add(m8, ModelKind::QuantileRange, s.members, "", true, false);
    const std::string title = "Quartile view of the tangle, " + std::to_string(s.members) +
                              " members, q = 8 (Athawale et al. 2021, Fig. 6)";
    run.writeFigure("figure.png", renderPanel(makePanel(title, run.items(), 5)));
    std::vector<std::string> setup = {
        "Tangle on " + std::to_string(s.dims) + "³ grid points, " + noiseLine(s.members),
        "Empirical quantiles, q = 8: quartile-lower integrates the TF over quantiles 1–2 "
        "([0, .25]), quartile-middle over 3–6, quartile-upper over 7–8 (SPEC §4).",
        kMembersLine};
    return run.finish(title, setup, {"figure.png"});
}

// ---- downsampling: spheres (Fig. 8), chest (teaser b / Fig. 9) --------------------------------

ExperimentResult runDownsampled(const std::string& name, const fs::path& dir, ScalarField field,
                                const ExperimentOptions& options, const std::string& tfFile,
                                const std::string& title, std::vector<std::string> setup,
                                const Camera* camera) {
    constexpr int kBrick = 4;
    Run run(name, dir, options, resolveSizes(name, options));
    const Sizes& s = run.sizes();
    run.loadTf(tfFile);
    // `build --downsample`'s default estimate (kde, Silverman), as a user's build gets.
    const DensityEstimate density = defaultDensity(true);
    ModelVolume reduced = run.buildBricks(field, kBrick, 8, 4, density);
    {
        // The full-resolution truth: a mean model of the field, without the arrays it does not
        // need for rendering (σ), to keep a 512³ run within a few GiB.
        ModelVolume truthModel = modelFromField(field);
        truthModel.stddev = {};
        field.values = {};
        field.values.shrink_to_fit();
        run.setView(truthModel.bounds);
        if (camera) run.setCamera(*camera);
        run.renderTruth(truthModel, 1, kBrick * kBrick * kBrick);
    }
    const int samples = kBrick * kBrick * kBrick;
    for (ModelKind k :
         {ModelKind::Mean, ModelKind::Uniform, ModelKind::Gaussian, ModelKind::GmmMc,
          ModelKind::GmmOrdered, ModelKind::QuantileRange, ModelKind::QuantileMean, ModelKind::Iqr})
        run.add(reduced, k, samples);
    run.addPanelItem(tfItem(run.tf(), std::min(kThumbMax, s.image)));
    const double scale = run.writeDifferenceImages();
    run.writeFigure("figure.png", renderPanel(makePanel(title, run.items(), 5)));
    setup.push_back(
        "Difference images: per-pixel |Δ mean RGB| against the ground truth, blue (0) "
        "to yellow (" +
        fmt("%.3f", scale) + ", the largest difference of any model).");
    setup.push_back(
        "Reduced by " + std::to_string(kBrick) + "³ bricks to " +
        std::to_string(reduced.grid.dims[0]) + "×" + std::to_string(reduced.grid.dims[1]) + "×" +
        std::to_string(reduced.grid.dims[2]) + " voxels of 64 samples each (SPEC §2); " +
        densityName(density) + " quantiles q = 8 (`build --downsample`'s default" +
        (density == DensityEstimate::Kde ? ": Silverman's bandwidth, tails at ε = 1/128" : "") +
        "; `downsample-estimators` compares the estimators), GMM K = 4; gmm-mc averages " +
        std::to_string(s.realizations) + " realizations.");
    setup.push_back(
        "Ground-truth memory is the full-resolution field relative to the reduced mean "
        "field (64).");
    return run.finish(title, setup, {"figure.png"});
}

ExperimentResult runSpheres(const fs::path& dir, const ExperimentOptions& options) {
    const Sizes s = resolveSizes("spheres", options);
    if (options.log)
        std::fprintf(stderr, "udvr experiment spheres: generating nested spheres %d³\n", s.dims);
    ScalarField field = makeNestedSpheres(s.dims, s.dims, s.dims);
    const std::string title = "Nested spheres " + std::to_string(s.dims) +
                              "³ reduced by 4³ bricks (Athawale et al. 2021, Fig. 8)";
    return runDownsampled("spheres", dir, std::move(field), options, "spheres.json", title,
                          {"Nested spheres (shells valued 25, 50, 75, 100 from the inside out, 0 "
                           "between) on " +
                           std::to_string(s.dims) +
                           "³ grid points; ground truth "
                           "rendered at full resolution."},
                          nullptr);
}

fs::path chestPath(const ExperimentOptions& options) {
    return sharedDataPath(options, "chest-ct/chest.nhdr");
}

ExperimentResult runChest(const fs::path& dir, const ExperimentOptions& options) {
    const fs::path path = chestPath(options);
    if (path.empty() || !fs::exists(path))
        UDVR_FAIL(
            "experiment 'chest' needs the chest CT at "
            << (path.empty() ? std::string("<shared data>/chest-ct/chest.nhdr") : path.string())
            << ", which is absent; set UDVR_DATA_DIR to the folder holding chest-ct/");
    ScalarField field = readField(path);
    if (options.log)
        std::fprintf(stderr, "udvr experiment chest: read %s (%d×%d×%d)\n", path.string().c_str(),
                     field.grid.dims[0], field.grid.dims[1], field.grid.dims[2]);
    const Camera cam = chestCamera(field.grid.bounds());
    const std::string title =
        "Chest CT reduced by 4³ bricks: bone (gray) and soft tissue (red) "
        "(Athawale et al. 2021, teaser b / Fig. 9)";
    return runDownsampled(
        "chest", dir, std::move(field), options, "chest-ct.json", title,
        {"Chest CT (LIDC, 8-bit) from `" + path.string() +
         "`, 256×256×133, spacing 1.40625×1.40625×2.5 mm; plays the paper's OBELIX torso."},
        &cam);
}

ExperimentResult runOneUnplanned(const std::string& name, const fs::path& dir,
                                 const ExperimentOptions& options) {
    if (name == "tangle" || name == "teardrop") return runEnsembleExperiment(name, dir, options);
    if (name == "tangle-sweep") return runSweep(dir, options);
    if (name == "quartiles") return runQuartiles(dir, options);
    if (name == "spheres") return runSpheres(dir, options);
    if (name == "chest") return runChest(dir, options);
    if (name == "tooth2d") return runTooth2d(dir, options);
    if (name == "fiber") return runFiber(dir, options);
    if (name == "fiber-isabel") return runFiberIsabel(dir, options);
    if (name == "quantile-levels") return runQuantileLevels(dir, options);
    if (name == "downsample-estimators") return runDownsampleEstimators(dir, options);
    std::string names;
    for (const std::string& n : experimentNames()) names += n + ", ";
    UDVR_FAIL("unknown experiment '" << clipForMessage(name) << "'"
                                     << didYouMean(name, experimentNames()) << " (expected one of "
                                     << names << "all)");
}

/// Cost before work (issue 35): the whole run estimated before it starts (one line when over
/// 10 s, with what would shorten it), then a progress line with the time left every 10 s.
ExperimentResult runOne(const std::string& name, const fs::path& dir,
                        const ExperimentOptions& options) {
    const auto& names = experimentNames();
    if (!options.log || std::find(names.begin(), names.end(), name) == names.end())
        return runOneUnplanned(name, dir, options);
    // The inputs' checks first: a bad one is one error line, with no estimate before it.
    const fs::path tfDir = options.tfDir.empty() ? locateTfDir() : options.tfDir;
    if (!fs::is_directory(tfDir))
        UDVR_FAIL("transfer-function folder " << tfDir.string()
                                              << " not found (use --tf-dir or UDVR_TF_DIR)");
    const std::string line = estimateLine(name, options);
    if (!line.empty()) {
        // The folder too (as Run makes it), so that a bad -o is the one line.
        std::error_code ec;
        fs::create_directories(dir / "images", ec);
        if (ec)
            UDVR_FAIL("cannot create output directory " << (dir / "images").string() << ": "
                                                        << ec.message());
        std::fprintf(stderr, "%s\n", line.c_str());
    }
    const Work work = planExperiment(name, resolveSizes(name, options), options);
    const Speed& speed = machineSpeed();
    ExperimentProgress progress(name, work.buildMs * speed.build, work.frameMs * speed.frame, true);
    struct Current {
        explicit Current(ExperimentProgress* p) { ExperimentProgress::current() = p; }
        ~Current() { ExperimentProgress::current() = nullptr; }
    } current(&progress);
    return runOneUnplanned(name, dir, options);
}

fs::path executableDir() {
    std::error_code ec;
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    return ec ? fs::path() : exe.parent_path();
}

}  // namespace

const std::vector<std::string>& experimentNames() {
    static const std::vector<std::string> names = {"tangle",
                                                   "tangle-sweep",
                                                   "teardrop",
                                                   "quartiles",
                                                   "spheres",
                                                   "chest",
                                                   "tooth2d",
                                                   "fiber",
                                                   "fiber-isabel",
                                                   "quantile-levels",
                                                   "downsample-estimators"};
    return names;
}

fs::path locateTfDir() {
    if (const char* env = std::getenv("UDVR_TF_DIR"); env && *env) {
        if (fs::is_directory(env)) return env;
        UDVR_FAIL("UDVR_TF_DIR=" << env << " is not a directory");
    }
    std::vector<fs::path> candidates;
    const fs::path exe = executableDir();
    if (!exe.empty())
        for (fs::path p = exe; !p.empty() && p != p.root_path(); p = p.parent_path())
            candidates.push_back(p / "data" / "tf");
    // The source tree this library was built from (src/udvr/eval/ → repo root).
    candidates.push_back(
        fs::path(__FILE__).parent_path().parent_path().parent_path().parent_path() / "data" / "tf");
    candidates.push_back(fs::current_path() / "data" / "tf");
    for (const fs::path& c : candidates)
        if (fs::exists(c / "tangle.json")) return c;
    UDVR_FAIL(
        "cannot find the transfer functions (data/tf/tangle.json) beside the executable, in "
        "the source tree or the working directory; set UDVR_TF_DIR");
}

fs::path locateDataDir() {
    if (const char* env = std::getenv("UDVR_DATA_DIR"); env && *env) return env;
    std::vector<fs::path> candidates;
    const fs::path exe = executableDir();
    if (!exe.empty())
        for (fs::path p = exe; !p.empty() && p != p.root_path(); p = p.parent_path())
            candidates.push_back(p.parent_path() / "shared" / "data");
    candidates.push_back(
        fs::path(__FILE__).parent_path().parent_path().parent_path().parent_path().parent_path() /
        "shared" / "data");
    candidates.push_back(fs::current_path().parent_path() / "shared" / "data");
    for (const fs::path& c : candidates)
        if (fs::is_directory(c)) return c;
    return {};
}

std::vector<ExperimentResult> runExperiments(const std::string& name, const fs::path& outDir,
                                             const ExperimentOptions& options) {
    // Not the folder of the TFs or the data: the figures, tables and report would land among
    // (and over) the inputs (issue 34).
    std::vector<std::string> inputs = {options.tfDir.string(), options.dataDir.string()};
    try {
        if (options.tfDir.empty()) inputs[0] = locateTfDir().string();
    } catch (const UdvrError&) {  // the experiment says so when it needs them
    }
    if (options.dataDir.empty()) inputs[1] = locateDataDir().string();
    requireOutputsNotInputs({{"the output folder", outDir.string()}}, inputs);
    if (name != "all") return {runOne(name, outDir, options)};
    std::vector<ExperimentResult> results;
    std::vector<std::string> skipped;
    for (const std::string& n : experimentNames()) {
        if (n == "chest" || n == "tooth2d" || n == "fiber-isabel") {
            const fs::path p = n == "chest"     ? chestPath(options)
                               : n == "tooth2d" ? toothPath(options)
                                                : isabelPath(options, 2);
            if (p.empty() || !fs::exists(p)) {
                const std::string why = n + " (no data at " +
                                        (p.empty() ? std::string("<shared data>") : p.string()) +
                                        ")";
                if (options.log)
                    std::fprintf(stderr, "udvr experiment: skipping %s\n", why.c_str());
                skipped.push_back(why);
                continue;
            }
        }
        results.push_back(runOne(n, outDir / n, options));
    }
    writeFileAtomically(outDir / "report.md", summaryReport(results, skipped));
    return results;
}

}  // namespace udvr
