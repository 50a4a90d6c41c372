#pragma once
// What the experiments of experiments.cpp and experiment_*.cpp share (eval/ internal): sizes
// after --quick, labels, figure panels, and Run — one experiment's directory, log, transfer
// function (1D or 2D), camera, ground truth, result rows and report.
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "udvr/classify/model_families.h"
#include "udvr/classify/transfer_function_2d.h"
#include "udvr/eval/experiment_plan.h"
#include "udvr/eval/experiments.h"
#include "udvr/eval/figure.h"
#include "udvr/eval/image_metrics.h"
#include "udvr/eval/report.h"
#include "udvr/io/image.h"
#include "udvr/io/transfer_function_io.h"
#include "udvr/render/frame_estimate.h"
#include "udvr/render/render.h"
#include "udvr/stats/build_model.h"
#include "udvr/util/atomic_file.h"
#include "udvr/util/check.h"

namespace udvr::experiment_detail {
namespace fs = std::filesystem;

using Clock = std::chrono::steady_clock;

inline double secondsSince(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

inline std::string fmt(const char* format, double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, format, v);
    return buf;
}

/// Largest thumbnail side in figure panels; full-size images are written separately.
constexpr int kThumbMax = 256;
/// The peer harness's default view (bench/peer/vtk_render.py).
constexpr double kAzimuth = 30.0, kElevation = 20.0;
/// Seed of every ensemble, so runs are reproducible and the sweep's member sets nest.
constexpr std::uint64_t kNoiseSeed = 1;
/// The teardrop's noise magnitudes relative to the tangle's (see runEnsembleExperiment).
constexpr double kTeardropNoiseScale = 0.25;

/// Sizes of one experiment after --quick and the test overrides.
struct Sizes {
    int dims = 64;
    int members = 50;
    int image = 512;
    int realizations = 200;
    std::vector<int> sweepMembers{5, 10, 20, 50};
};

/// The sizes of experiment `name`: its own (full or --quick), with the test overrides of `o`,
/// which may only make it smaller (an override over the full run's size is a UdvrError: a
/// realizations=10**9 from Python would run for days, issue 34).
inline Sizes resolveSizes(const std::string& name, const ExperimentOptions& o) {
    if (o.dims != 0 || o.members != 0 || o.imageSize != 0 || o.realizations != 0) {
        ExperimentOptions full = o;
        full.quick = false;
        full.dims = full.members = full.imageSize = full.realizations = 0;
        const Sizes f = resolveSizes(name, full);
        const std::pair<int, int> given[] = {{o.dims, f.dims},
                                             {o.members, f.members},
                                             {o.imageSize, f.image},
                                             {o.realizations, f.realizations}};
        const char* names[] = {"dims", "members", "image_size", "realizations"};
        for (int i = 0; i < 4; ++i)
            if (given[i].first < 0 || given[i].first > given[i].second)
                UDVR_FAIL("experiment " << name << ": " << names[i] << " " << given[i].first
                                        << " is out of range; the overrides make smaller runs "
                                           "(1 to the full run's "
                                        << given[i].second << ", or 0 for the experiment's own)");
    }
    Sizes s;
    const bool q = o.quick;
    if (name == "tangle" || name == "quartiles") {
        s.dims = 64, s.members = 50, s.image = q ? 128 : 512, s.realizations = q ? 20 : 200;
    } else if (name == "tangle-sweep") {
        s.dims = q ? 32 : 64, s.image = q ? 96 : 256;
    } else if (name == "teardrop") {
        s.dims = q ? 48 : 64, s.members = 50, s.image = q ? 128 : 512;
        s.realizations = q ? 20 : 200;
    } else if (name == "spheres") {
        s.dims = q ? 128 : 512, s.image = q ? 128 : 512, s.realizations = q ? 20 : 200;
    } else if (name == "chest") {
        s.image = q ? 128 : 512, s.realizations = q ? 20 : 200;
    } else if (name == "tooth2d") {
        s.image = q ? 96 : 512, s.realizations = q ? 20 : 200;
    } else if (name == "fiber") {
        s.dims = q ? 64 : 128, s.image = q ? 96 : 384;
    } else if (name == "fiber-isabel") {
        s.image = q ? 96 : 384;
    } else if (name == "downsample-estimators") {
        s.dims = q ? 128 : 512, s.image = q ? 128 : 512;  // spheres at full resolution
    } else if (name == "quantile-levels") {
        s.dims = q ? 32 : 64, s.members = 50, s.image = q ? 96 : 512;
    }
    if (o.dims > 0) s.dims = o.dims;
    if (o.members > 0) s.members = o.members;
    if (o.imageSize > 0) s.image = o.imageSize;
    if (o.realizations > 0) s.realizations = o.realizations;
    if (!o.sweepMembers.empty()) s.sweepMembers = o.sweepMembers;
    return s;
}

inline std::string slug(const std::string& label) {
    std::string out;
    for (char c : label) {
        if (std::isalnum(static_cast<unsigned char>(c)))
            out += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        else if ((c == ' ' || c == '-' || c == '_' || c == '/') && !out.empty() &&
                 out.back() != '-')
            out += '-';
    }
    while (!out.empty() && out.back() == '-') out.pop_back();
    return out;
}

inline std::string modelLabel(ModelKind kind, int q) {
    std::string s(modelName(kind));
    if (modelFamily(kind).labelShowsQ) s += " q=" + std::to_string(q);
    return s;
}

inline std::string densityName(DensityEstimate d) { return densityEstimateName(d); }

/// Whether a model's classification reads the quantile boundaries (the IQR's come from them too).
inline bool usesQuantiles(ModelKind kind) {
    return (modelRow(kind).arrays & (kArrayQuantiles | kArrayIqr)) != 0;
}

/// A rendered image on its way into the panel.
struct PanelItem {
    std::string label;
    std::vector<std::string> caption;
    ImageRgba image;
    ImageRgba diff;        // empty = no difference image under it
    std::string diffFile;  // where the difference image goes; empty = none wanted
};

inline ImageRgba thumbnail(const ImageRgba& image) {
    const int side = std::max(image.width, image.height);
    const int factor = (side + kThumbMax - 1) / kThumbMax;
    return factor <= 1 ? image : downsampleImage(image, factor);
}

/// Rows of `columns` images, each followed by the row of their difference images (if any).
inline FigurePanel makePanel(const std::string& title, const std::vector<PanelItem>& items,
                             int columns) {
    FigurePanel panel;
    panel.title = title;
    panel.columns = columns;
    for (std::size_t start = 0; start < items.size(); start += static_cast<std::size_t>(columns)) {
        const std::size_t end = std::min(items.size(), start + static_cast<std::size_t>(columns));
        bool anyDiff = false;
        for (std::size_t i = start; i < end; ++i) {
            panel.cells.push_back({thumbnail(items[i].image), items[i].caption});
            anyDiff = anyDiff || items[i].diff.width > 0;
        }
        for (std::size_t i = end; i < start + static_cast<std::size_t>(columns); ++i)
            panel.cells.push_back({});
        if (!anyDiff) continue;
        for (std::size_t i = start; i < end; ++i) {
            FigureCell c;
            if (items[i].diff.width > 0) {
                c.image = thumbnail(items[i].diff);
                c.caption = {"difference", items[i].label};
            }
            panel.cells.push_back(std::move(c));
        }
        for (std::size_t i = end; i < start + static_cast<std::size_t>(columns); ++i)
            panel.cells.push_back({});
    }
    return panel;
}

/// Everything one experiment shares: its directory, log, TF, camera, truth and table.
class Run {
  public:
    Run(std::string name, fs::path dir, const ExperimentOptions& options, Sizes sizes)
        : options_(options), sizes_(std::move(sizes)), t0_(Clock::now()) {
        result_.name = std::move(name);
        result_.dir = std::move(dir);
        // Inputs are checked before anything is created, so a failed run leaves no folders.
        const fs::path tfDir = options_.tfDir.empty() ? locateTfDir() : options_.tfDir;
        if (!fs::is_directory(tfDir))
            UDVR_FAIL("transfer-function folder " << tfDir.string()
                                                  << " not found (use --tf-dir or UDVR_TF_DIR)");
        std::error_code ec;
        fs::create_directories(result_.dir / "images", ec);
        if (ec)
            UDVR_FAIL("cannot create output directory " << (result_.dir / "images").string() << ": "
                                                        << ec.message());
    }

    const Sizes& sizes() const { return sizes_; }
    const ExperimentOptions& options() const { return options_; }
    ExperimentResult& result() { return result_; }

    void log(const std::string& message) const {
        if (options_.log)
            std::fprintf(stderr, "udvr experiment %s: %s\n", result_.name.c_str(), message.c_str());
    }

    /// Load data/tf/<file>, keep a copy beside the results (tf.json) and draw it.
    void loadTf(const std::string& file) {
        const fs::path dir = options_.tfDir.empty() ? locateTfDir() : options_.tfDir;
        const fs::path path = dir / file;
        if (!fs::exists(path))
            UDVR_FAIL("transfer function " << path.string() << " not found (set UDVR_TF_DIR)");
        tf_ = readTransferFunction(path);
        std::ifstream in(path, std::ios::binary);
        std::ostringstream os;
        os << in.rdbuf();
        writeFile("tf.json", os.str());
        tfFile_ = file;
    }
    const TransferFunction1D& tf() const { return tf_; }
    const std::string& tfFile() const { return tfFile_; }

    /// Classify with a 2D TF from now on (data/tf2/<file> or a TF2 built by the experiment,
    /// `text` its widget JSON, kept beside the results as tf2.json).
    void setTf2(TransferFunction2D tf, const std::string& file, const std::string& text) {
        tf.validate();
        tf2_ = std::move(tf);
        tf2File_ = file;
        writeFile("tf2.json", text);
    }
    const TransferFunction2D& tf2() const { return *tf2_; }
    /// Bivariate fields: render `first` with y from `second` (both outlive the run's renders).
    void pairSecond(const ModelVolume& first, const ModelVolume& second) {
        second_[&first] = &second;
    }
    /// A claim checked by the experiment itself (added after the table's claims).
    void addClaim(ClaimCheck c) { extraClaims_.push_back(std::move(c)); }
    /// A report section after the table (Markdown).
    void addSection(std::string title, std::string markdown) {
        sections_.push_back({std::move(title), std::move(markdown)});
    }

    /// Camera and image settings for everything rendered in this run (from the truth's bounds).
    void setView(const std::array<double, 6>& bounds, double azimuth = kAzimuth,
                 double elevation = kElevation, double zoom = 1.0) {
        settings_.width = settings_.height = sizes_.image;
        settings_.camera = defaultCamera(bounds, azimuth, elevation, zoom);
        settings_.realizations = sizes_.realizations;
    }
    void setCamera(const Camera& camera) { settings_.camera = camera; }
    /// Ray step in world units for every render (0: SPEC §5's default).
    void setStep(double step) { settings_.step = step; }
    const RenderSettings& settings() const { return settings_; }

    /// Render one image with its time; one line on stderr.
    ImageRgba render(const ModelVolume& model, ModelKind kind, const std::string& label,
                     double* ms) {
        RenderStats stats;
        const auto frame = [&](const RenderSettings& at) {
            if (!tf2_) return renderVolume(model, kind, tf_, at, &stats);
            if (const auto it = second_.find(&model); it != second_.end())
                return renderBivariate(model, *it->second, kind, *tf2_, at, &stats);
            return renderVolume(model, kind, *tf2_, at, &stats);
        };
        // Cost before work (issue 35): a long frame is announced with what would shorten it;
        // the frame's own progress lines (every 10 s off a terminal) give the time left, and the
        // experiment's progress line takes the frame's estimate as this stage's.
        const auto& b = model.bounds;
        const double step = settings_.step > 0.0
                                ? settings_.step
                                : 0.5 * (model.fullResMinSpacing > 0.0 ? model.fullResMinSpacing
                                                                       : model.grid.minSpacing());
        StageScope stage(frameWork(kind, double(settings_.width) * settings_.height,
                                   std::max({b[1] - b[0], b[3] - b[2], b[5] - b[4]}) / step,
                                   double(model.voxelCount()), settings_.realizations,
                                   model.memberCount,
                                   !tf2_                   ? TfKind::OneD
                                   : second_.count(&model) ? TfKind::Bivariate
                                                           : TfKind::TwoD));
        if (options_.log) {
            const FrameEstimate e =
                estimateFrame(settings_, rendersRealizations(kind), [&](const RenderSettings& at) {
                    frame(at);
                    return stats.milliseconds;
                });
            // The probes' estimate, kept within 5x of the plan's (a probe of a few pixels under
            // load can be off by 100x: 543 s said for a 0.2 s frame).
            const double frameMs = stage.refine(e.ms);
            if (frameMs > kLongFrameMs)
                log(label + ": this frame will take about " + fmt("%.0f", frameMs / 1000.0) +
                    " s (probes up to " + std::to_string(e.width) + "x" + std::to_string(e.height) +
                    " took " + fmt("%.2f", e.probeMs / 1000.0) + " s); shorter: " +
                    (options_.quick ? std::string("a smaller --size (Python: image_size)")
                                    : std::string("--quick or a smaller --size")));
        }
        ImageRgba img = frame(settings_);
        *ms = stats.milliseconds;
        log("rendered " + label + " (" + std::to_string(settings_.width) + "x" +
            std::to_string(settings_.height) + ") in " + fmt("%.1f", stats.milliseconds) + " ms");
        return img;
    }

    /// Render the ground truth (a mean model of the deterministic field) and record it.
    /// A new truth starts a new dataset: no members image until addMembers is called again.
    void renderTruth(const ModelVolume& truthModel, int memberCount, double memory) {
        double ms = 0;
        truth_ = render(truthModel, ModelKind::Mean, "ground truth", &ms);
        members_ = {};
        ResultRow row;
        row.experiment = result_.name;
        row.label = "ground truth";
        row.model = "ground-truth";
        row.members = memberCount;
        row.rmse = imageRmse(truth_, truth_);
        row.renderMs = ms;
        row.memoryRatio = memory;
        row.image = "images/ground-truth.png";
        writeImage(row.image, truth_);
        result_.rows.push_back(row);
        items_.push_back({row.label, {row.label, "RMSE " + fmt("%.4f", row.rmse)}, truth_, {}, {}});
    }
    const ImageRgba& truth() const { return truth_; }

    /// The ensemble's own expected image (model `members`, issue 12): rendered and recorded as
    /// a row, and every row added after it is compared with it too (ResultRow::rmseMembers).
    void addMembers(const Ensemble& ensemble, const std::string& labelSuffix = "",
                    bool inPanel = true, bool withDiff = true) {
        add(membersModel(ensemble), ModelKind::Members, ensemble.members, labelSuffix, inPanel,
            withDiff);
    }

    /// Render `kind` of `model`, compare with the truth (and the members image, once there is
    /// one), write the image and its difference.
    ResultRow add(const ModelVolume& model, ModelKind kind, int memberCount,
                  const std::string& labelSuffix = "", bool inPanel = true, bool withDiff = true) {
        const int q = usesQuantiles(kind) ? model.quantileCount : 0;
        const int k = (modelRow(kind).arrays & kArrayGmm) ? model.gmmComponents : 0;
        ResultRow row;
        row.experiment = result_.name;
        row.label = modelLabel(kind, q) + labelSuffix;
        row.model = std::string(modelName(kind));
        row.quantiles = q;
        row.gmmComponents = k;
        row.density = usesQuantiles(kind) ? model.density : "";
        row.members = memberCount;
        ImageRgba img = render(model, kind, row.label, &row.renderMs);
        row.rmse = imageRmse(img, truth_);
        if (readsMembers(kind)) members_ = img;
        if (members_.width > 0) row.rmseMembers = imageRmse(img, members_);
        row.memoryRatio = memoryRatio(kind, q, k, memberCount);
        const std::string base = "images/" + slug(row.label);
        row.image = base + ".png";
        writeImage(row.image, img);
        log(row.label + ": RMSE " + fmt("%.5f", row.rmse) +
            (members_.width > 0 ? ", against the members " + fmt("%.5f", row.rmseMembers) : ""));
        result_.rows.push_back(row);
        if (inPanel) {
            std::string line2 = "RMSE " + fmt("%.4f", row.rmse);
            std::string line3 =
                fmt("%.0f ms", row.renderMs) + ", mem " + fmt("%g", row.memoryRatio) + "x";
            items_.push_back({row.label,
                              {row.label, line2, line3},
                              std::move(img),
                              {},
                              withDiff ? base + "-diff.png" : std::string()});
        }
        return row;
    }

    /// Difference images of the panel's items, on one colour scale (the largest per-pixel
    /// difference of any of them) so they compare at a glance; written beside the images.
    double writeDifferenceImages() {
        double scale = 0.0;
        for (const PanelItem& it : items_)
            if (!it.diffFile.empty())
                for (float d : pixelDifferences(it.image, truth_))
                    scale = std::max(scale, static_cast<double>(d));
        if (scale <= 0.0) scale = 1.0;
        for (PanelItem& it : items_)
            if (!it.diffFile.empty()) {
                it.diff = differenceImage(it.image, truth_, scale);
                writeImage(it.diffFile, it.diff);
            }
        diffScale_ = scale;
        return scale;
    }
    double diffScale() const { return diffScale_; }

    /// An extra panel cell (e.g. the transfer function).
    void addPanelItem(PanelItem item) { items_.push_back(std::move(item)); }
    std::vector<PanelItem>& items() { return items_; }

    void writeImage(const std::string& rel, const ImageRgba& img) {
        writePng(result_.dir / rel, img);
        result_.files.emplace_back(rel);
    }
    void writeFigure(const std::string& rel, const ImageRgba& img) {
        writeFigurePng(result_.dir / rel, img);
        result_.files.emplace_back(rel);
    }
    void writeFile(const std::string& rel, const std::string& text) {
        writeFileAtomically(result_.dir / rel, text);
        result_.files.emplace_back(rel);
    }

    /// Write results.csv/json, claims and report.md; returns the result.
    ExperimentResult finish(const std::string& title, std::vector<std::string> setup,
                            const std::vector<std::string>& figures) {
        result_.claims = checkClaims(result_.name, result_.rows);
        result_.claims.insert(result_.claims.end(), extraClaims_.begin(), extraClaims_.end());
        writeResultsCsv(result_.dir / "results.csv", result_.rows);
        result_.files.emplace_back("results.csv");
        writeResultsJson(result_.dir / "results.json", result_.rows);
        result_.files.emplace_back("results.json");
        result_.files.emplace_back("report.md");
        result_.seconds = secondsSince(t0_);
        const Camera& c = settings_.camera;
        setup.push_back(
            "Images " + std::to_string(settings_.width) + "×" + std::to_string(settings_.height) +
            ", camera at (" + fmt("%.3g", c.position[0]) + ", " + fmt("%.3g", c.position[1]) +
            ", " + fmt("%.3g", c.position[2]) + ") looking at (" + fmt("%.3g", c.focalPoint[0]) +
            ", " + fmt("%.3g", c.focalPoint[1]) + ", " + fmt("%.3g", c.focalPoint[2]) +
            "), view angle " + fmt("%g", c.viewAngleDeg) + "°; white background.");
        if (!tfFile_.empty() && !tf2_)
            setup.push_back("Transfer function `data/tf/" + tfFile_ + "` (copied to `tf.json`).");
        if (tf2_)
            setup.push_back("2D transfer function " + tf2File_ + " (" +
                            std::to_string(tf2_->width) + "×" + std::to_string(tf2_->height) +
                            " raster; widgets copied to `tf2.json`).");
        writeFileAtomically(result_.dir / "report.md",
                            experimentReport(result_, title, setup, figures, sections_));
        for (const ClaimCheck& cl : result_.claims) log(cl.verdict + ": " + cl.claim);
        log("done in " + fmt("%.1f", result_.seconds) + " s → " + result_.dir.string());
        return result_;
    }

    ModelVolume build(const Ensemble& ensemble, int q, int gmm, DensityEstimate density) {
        BuildOptions bo;
        bo.quantiles = q;
        bo.gmmComponents = gmm;
        bo.density = density;
        bo.source = result_.name + " ensemble";
        BuildReport rep;
        const StageScope stage(
            buildWork(double(ensemble.grid.pointCount()), ensemble.members, gmm, density));
        ModelVolume m = buildModel(ensemble, bo, &rep);
        log("built " + describeBuild(q, gmm, density) + " from " +
            std::to_string(ensemble.members) + " members in " + fmt("%.2f", rep.seconds) + " s");
        return m;
    }
    ModelVolume buildBricks(const ScalarField& field, int k, int q, int gmm,
                            DensityEstimate density = DensityEstimate::Empirical) {
        BuildOptions bo;
        bo.quantiles = q;
        bo.gmmComponents = gmm;
        bo.density = density;  // kde: Silverman's bandwidth, tails at 1/(2n)
        bo.source = result_.name + " " + std::to_string(k) + "^3 bricks";
        BuildReport rep;
        const Grid3 reduced = downsampledGrid(field.grid, k);
        const StageScope stage(
            buildWork(double(reduced.pointCount()), k * k * k, gmm, density, true));
        ModelVolume m = buildModelDownsampled(field, k, bo, &rep);
        log("built " + describeBuild(q, gmm, density) + " from " + std::to_string(k) +
            "³ bricks (" + std::to_string(m.grid.dims[0]) + "×" + std::to_string(m.grid.dims[1]) +
            "×" + std::to_string(m.grid.dims[2]) + ") in " + fmt("%.2f", rep.seconds) + " s");
        return m;
    }

  private:
    static std::string describeBuild(int q, int gmm, DensityEstimate density) {
        std::string s = "model (q=" + std::to_string(q) + ", " + densityName(density);
        if (gmm > 0) s += ", gmm " + std::to_string(gmm);
        return s + ")";
    }

    const ExperimentOptions& options_;
    Sizes sizes_;
    Clock::time_point t0_;
    ExperimentResult result_;
    TransferFunction1D tf_;
    std::string tfFile_;
    std::optional<TransferFunction2D> tf2_;
    std::string tf2File_;
    std::map<const ModelVolume*, const ModelVolume*> second_;
    std::vector<ClaimCheck> extraClaims_;
    std::vector<ReportSection> sections_;
    RenderSettings settings_;
    ImageRgba truth_;
    ImageRgba members_;  // the last members image (addMembers); empty before
    std::vector<PanelItem> items_;
    double diffScale_ = 0.0;
};

/// A side view of a volume with its long axis z vertical (up), from azimuth `az` degrees about z
/// (0 = looking along +y) and elevation `el` above the xy plane, `zoom`× closer than the
/// bounding-sphere fit.
inline Camera sideCamera(const std::array<double, 6>& b, double az, double el, double zoom) {
    Camera cam;
    cam.focalPoint = {(b[0] + b[1]) / 2, (b[2] + b[3]) / 2, (b[4] + b[5]) / 2};
    const double radius =
        0.5 * std::sqrt((b[1] - b[0]) * (b[1] - b[0]) + (b[3] - b[2]) * (b[3] - b[2]) +
                        (b[5] - b[4]) * (b[5] - b[4]));
    const double dist = radius / std::sin(cam.viewAngleDeg * std::numbers::pi / 360.0) / zoom;
    const double a = az * std::numbers::pi / 180.0, e = el * std::numbers::pi / 180.0;
    cam.position = {cam.focalPoint[0] + dist * std::cos(e) * std::sin(a),
                    cam.focalPoint[1] - dist * std::cos(e) * std::cos(a),
                    cam.focalPoint[2] + dist * std::sin(e)};
    cam.viewUp = {0, 0, 1};
    return cam;
}

/// The chest CT's view: from the front (camera on −y, the anterior side of this scan, head up),
/// 1.5× closer than the bounding-sphere fit (the body fills only part of its box).
inline Camera chestCamera(const std::array<double, 6>& bounds) {
    return sideCamera(bounds, 0.0, 0.0, 1.5);
}

inline PanelItem tfItem(const TransferFunction1D& tf, int side) {
    PanelItem item;
    item.label = "transfer function";
    item.caption = {"transfer function", "opacity (line), colour (bar)"};
    item.image = renderTransferFunction(tf, side, side);
    return item;
}

/// A file of the shared real data (`rel` under ../shared/data or --data-dir); empty if no data
/// folder is found.
inline fs::path sharedDataPath(const ExperimentOptions& options, const std::string& rel) {
    const fs::path dir = options.dataDir.empty() ? locateDataDir() : options.dataDir;
    return dir.empty() ? fs::path() : dir / rel;
}
/// The tooth CT of tooth2d.
inline fs::path toothPath(const ExperimentOptions& options) {
    return sharedDataPath(options, "tooth/tooth.nhdr");
}

/// Isabel's wind speed at time step t (fiber-isabel).
inline fs::path isabelPath(const ExperimentOptions& options, int step) {
    return sharedDataPath(options, "isabel-windspeed/windspeed_t0" + std::to_string(step) + ".vti");
}

// Experiments in their own files.
ExperimentResult runTooth2d(const fs::path& dir, const ExperimentOptions& options);  // Fig. 10
ExperimentResult runFiber(const fs::path& dir, const ExperimentOptions& options);    // Fig. 11
ExperimentResult runFiberIsabel(const fs::path& dir, const ExperimentOptions& options);
ExperimentResult runQuantileLevels(const fs::path& dir, const ExperimentOptions& options);
ExperimentResult runDownsampleEstimators(const fs::path& dir, const ExperimentOptions& options);

}  // namespace udvr::experiment_detail
