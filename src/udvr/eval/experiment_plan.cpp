#include "udvr/eval/experiment_plan.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>

#include "udvr/classify/model_families.h"
#include "udvr/data/noise.h"
#include "udvr/data/synthetic.h"
#include "udvr/eval/experiment_run.h"
#include "udvr/render/frame_estimate.h"
#include "udvr/render/render.h"
#include "udvr/util/progress.h"

namespace udvr::experiment_detail {
namespace {

// ---- cost factors ------------------------------------------------------------------------------
// Measured once (issue 35, 2026-12-02) on the development machine (2 cores shared, load ~4) from
// the "rendered … in N ms" and "built … in N s" lines of `udvr experiment tangle --quick` (64³,
// 128², 20 realizations), `tooth2d --quick` (2D TF, 96²), `spheres --quick` (kde bricks) and
// `downsample-estimators --quick`: a frame's ms divided by pixels × ray steps (the volume's
// longest extent over the ray step), a build's by voxels × samples. The speed probe below took
// kProbeBuildMs at the same time, so estimates scale by this machine's probe over that. Empty-space
// skipping and early ray termination make a frame's cost depend on the data and TF too (factors of
// 2–3 between datasets): the progress line corrects its time left by the stages done so far.
constexpr double kProbeBuildMs = 100.0;

// Per model, ns per pixel × ray step at the reference speed (ModelFamily::nsPerStep): 1D TF as
// above; gmm-mc per realization, besides kGmmMcNsPerVoxel, from the tangle's gmm-mc frames at
// 128² (41 ms a realization) and 512² (287 ms), a + b·pixels; members per member; 2D TF from
// tooth2d (the fiber for bivariate fields, 96², a ray step of 0.1 spacings). The fast 2D
// gaussian (issue 33): ~10× quantile-mean's 2D frame; the 2D uniform the exact one's order.
// Models without a measured value take these defaults per TF kind.
constexpr std::array<double, 3> kDefaultNsPerStep{40.0, 100.0, 300.0};

/// tooth2d's fast 2D gaussian, ns per pixel × ray step at the reference speed: `tooth2d --quick`
/// on 2026-12-02 (AVX-512, load 7, speed probe 199 ms): 37.2 and 29.8 s for its two 96² frames
/// of 320 steps, 5700 ns at the reference speed (the row's 200 ns, from the tangle, made the plan
/// 28x short there; the uniform frames the plan still listed and the run no longer renders had
/// hidden it).
constexpr double kTooth2dGaussianNs = 5700.0;
/// tooth2d's fast 2D uniform (by columns), likewise: `tooth2d --quick` on 2026-12-05 (AVX-512,
/// load ~1, speed probe 6.2 ms): 9.25 and 5.35 s for its two 96² frames of 320 steps, ~40,000 ns
/// at the reference speed (the uniform row's 2D factor, from the tangle, is 8x short here).
constexpr double kTooth2dUniformNs = 40000.0;

/// gmm-mc: ns per model voxel and realization (drawing the realization), see above.
constexpr double kGmmMcNsPerVoxel = 94.0;

/// ns per voxel × sample of a build at the reference speed.
double nsPerSample(int gmmComponents, DensityEstimate density) {
    // Sorting for empirical quantiles; kde (tangle-sweep: 580–1340 ns) and dequantized solve
    // for each boundary.
    const double quantiles = density == DensityEstimate::Empirical ? 9.2 : 700.0;
    // The GMM's EM dominates: ~1700 ns a sample with K = 4, about linear in K.
    return quantiles + 425.0 * gmmComponents;
}

double probeMs(const std::function<void()>& f) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

/// Steps across a grid of `dims` points at SPEC §5's default step (half the full-resolution
/// spacing): twice the longest extent in spacings (anisotropic: the extent over the smallest).
double defaultSteps(int nx, int ny, int nz, double sx = 1, double sy = 1, double sz = 1) {
    const double extent = std::max({(nx - 1) * sx, (ny - 1) * sy, (nz - 1) * sz});
    return 2.0 * extent / std::min({sx, sy, sz});
}

double cube(double n) { return n * n * n; }

struct SharedVolume {
    const char* rel;
    int nx, ny, nz;
    double sx, sy, sz;
    bool integer;
};
constexpr SharedVolume kChest{"chest-ct/chest.nhdr", 256, 256, 133, 1.40625, 1.40625, 2.5, true};
constexpr SharedVolume kTooth{"tooth/tooth.nhdr", 103, 94, 161, 1, 1, 1, true};
constexpr SharedVolume kNeghip{"neghip/neghip.nhdr", 64, 64, 64, 1, 1, 1, true};

bool present(const ExperimentOptions& o, const char* rel) {
    const fs::path p = sharedDataPath(o, rel);
    return !p.empty() && fs::exists(p);
}

double bricks(const SharedVolume& v, int k) {
    return std::ceil(v.nx / double(k)) * std::ceil(v.ny / double(k)) * std::ceil(v.nz / double(k));
}

}  // namespace

Work buildWork(double voxels, int samples, int gmmComponents, DensityEstimate density,
               bool bricks) {
    Work w;
    w.builds = 1;
    w.buildMs = voxels * samples * nsPerSample(gmmComponents, density) * 1e-6;
    // Bricks of a field: many are constant or nearly (the space around an object), whose
    // statistics are quick; spheres and downsample-estimators --quick took 0.20 and 0.31 of
    // the ensembles' cost per sample.
    if (bricks) w.buildMs *= 0.25;
    return w;
}

Work frameWork(ModelKind kind, double pixels, double steps, double voxels, int realizations,
               int members, TfKind tf) {
    Work w;
    w.frames = 1;
    const int column = tf == TfKind::Bivariate ? 2 : tf == TfKind::TwoD ? 1 : 0;
    double ns = modelFamily(kind).nsPerStep[column];
    if (!(ns > 0.0)) ns = kDefaultNsPerStep[column];
    if (readsMembers(kind)) ns *= std::max(members, 1);
    w.frameMs = pixels * steps * ns * 1e-6;
    if (rendersRealizations(kind))
        w.frameMs = (w.frameMs + voxels * kGmmMcNsPerVoxel * 1e-6) * std::max(realizations, 1);
    return w;
}

Work planExperiment(const std::string& name, const Sizes& s, const ExperimentOptions& o) {
    Work w;
    const double px = double(s.image) * s.image;
    double voxels = 0.0;  // the model's, for gmm-mc
    const auto frame = [&](ModelKind k, double steps, int members = 1, TfKind tf = TfKind::OneD) {
        w += frameWork(k, px, steps, voxels, s.realizations, members, tf);
    };
    using K = ModelKind;
    const auto reducedModels = [&](double steps) {
        for (K k : {K::Mean, K::Uniform, K::Gaussian, K::GmmMc, K::GmmOrdered, K::QuantileRange,
                    K::QuantileMean, K::Iqr})
            frame(k, steps);
    };
    if (name == "tangle" || name == "teardrop") {
        const double steps = defaultSteps(s.dims, s.dims, s.dims);
        voxels = cube(s.dims);
        frame(K::Mean, steps);
        frame(K::Members, steps, s.members);
        w += buildWork(cube(s.dims), s.members, 4, DensityEstimate::Empirical);
        for (K k : {K::Mean, K::Uniform, K::Gaussian, K::GmmMc, K::GmmOrdered}) frame(k, steps);
        const int qs = name == "tangle" ? 3 : 1;
        for (int i = 1; i < qs; ++i)
            w += buildWork(cube(s.dims), s.members, 0, DensityEstimate::Empirical);
        for (int i = 0; i < qs; ++i) frame(K::QuantileRange, steps), frame(K::QuantileMean, steps);
        frame(K::Iqr, steps);
    } else if (name == "quartiles") {
        const double steps = defaultSteps(s.dims, s.dims, s.dims);
        frame(K::Mean, steps);
        frame(K::Members, steps, s.members);
        w += buildWork(cube(s.dims), s.members, 0, DensityEstimate::Empirical);
        for (K k : {K::QuartileLower, K::QuartileMiddle, K::QuartileUpper, K::QuantileRange})
            frame(k, steps);
    } else if (name == "tangle-sweep") {
        const double steps = defaultSteps(s.dims, s.dims, s.dims);
        frame(K::Mean, steps);
        for (int m : s.sweepMembers) {
            frame(K::Members, steps, m);
            for (DensityEstimate d : {DensityEstimate::Empirical, DensityEstimate::Kde})
                for (int i = 0; i < 3; ++i) {
                    w += buildWork(cube(s.dims), m, 0, d);
                    frame(K::QuantileRange, steps), frame(K::QuantileMean, steps);
                }
            frame(K::Mean, steps), frame(K::Gaussian, steps);
        }
    } else if (name == "spheres") {
        const double steps = defaultSteps(s.dims, s.dims, s.dims);
        voxels = cube(std::ceil(s.dims / 4.0));
        w += buildWork(voxels, 64, 4, defaultDensity(true), true);
        frame(K::Mean, steps);
        reducedModels(steps);
    } else if (name == "chest") {
        if (!present(o, kChest.rel)) return w;
        const SharedVolume& v = kChest;
        const double steps = defaultSteps(v.nx, v.ny, v.nz, v.sx, v.sy, v.sz);
        voxels = bricks(v, 4);
        w += buildWork(voxels, 64, 4, defaultDensity(true), true);
        frame(K::Mean, steps);
        reducedModels(steps);
    } else if (name == "tooth2d") {
        if (!present(o, kTooth.rel)) return w;
        const SharedVolume& v = kTooth;
        const double steps = defaultSteps(v.nx, v.ny, v.nz);
        frame(K::Mean, steps, 1, TfKind::TwoD);
        for (int k : {4, 2}) {
            w += buildWork(bricks(v, k), k * k * k, 0, DensityEstimate::Empirical, true);
            for (K m : kTooth2dModels) {
                if (m != K::Gaussian && m != K::Uniform) {
                    frame(m, steps, 1, TfKind::TwoD);
                    continue;
                }
                // The fast 2D gaussian visits every raster cell under ±7σ: its cost goes with the
                // TF2's raster and the σ of the bricks, not with quantile-mean's frame as the
                // row's factor (from the tangle) has it; on the tooth (raster 64×32) it took
                // 30–37 s a 96² frame at a probe speed of 2.0 (load 7): kTooth2dGaussianNs. The
                // fast 2D uniform likewise (its basis functions per sample go with the raster
                // and the bricks' spread): kTooth2dUniformNs.
                Work g = frameWork(m, px, steps, 0.0, 1, 1, TfKind::TwoD);
                g.frameMs *= (m == K::Gaussian ? kTooth2dGaussianNs : kTooth2dUniformNs) /
                             modelFamily(m).nsPerStep[1];
                w += g;
            }
        }
    } else if (name == "fiber" || name == "fiber-isabel") {
        const bool isabel = name == "fiber-isabel";
        if (isabel && !present(o, "isabel-windspeed/windspeed_t02.vti")) return w;
        const int n = s.dims, brick = isabel ? 2 : 4;
        voxels =
            isabel ? std::ceil(125 / 2.0) * std::ceil(125 / 2.0) * 13 : cube(std::ceil(n / 4.0));
        // fiber: a ray step of 0.1 grid spacings (ten steps a spacing).
        const double steps = isabel ? defaultSteps(125, 125, 25) : 10.0 * (n - 1);
        for (int i = 0; i < 2; ++i)
            w += buildWork(voxels, brick * brick * brick, 0, DensityEstimate::Empirical, true);
        frame(K::Mean, steps, 1, TfKind::Bivariate);
        for (K k : {K::Mean, K::Uniform, K::Gaussian, K::QuantileRange, K::QuantileMean})
            frame(k, steps, 1, TfKind::Bivariate);
    } else if (name == "quantile-levels") {
        const double steps = defaultSteps(s.dims, s.dims, s.dims);
        frame(K::Mean, steps);
        frame(K::Members, steps, s.members);
        for (int i = 0; i < 3; ++i) {
            w += buildWork(cube(s.dims), s.members, 0, DensityEstimate::Empirical);
            frame(K::QuantileRange, steps), frame(K::QuantileMean, steps);
        }
        const int sd = o.dims > 0 ? std::max(o.dims, 8) : o.quick ? 64 : 256;
        std::vector<std::pair<double, double>> reduced = {
            {cube(std::ceil(sd / 4.0)), defaultSteps(sd, sd, sd)}};
        if (present(o, kChest.rel))
            reduced.push_back({bricks(kChest, 4), defaultSteps(kChest.nx, kChest.ny, kChest.nz,
                                                               kChest.sx, kChest.sy, kChest.sz)});
        for (const auto& [rv, st] : reduced) {
            frame(K::Mean, st);
            for (int i = 0; i < 3; ++i) {
                w += buildWork(rv, 64, 0, DensityEstimate::Empirical, true);
                frame(K::QuantileRange, st), frame(K::QuantileMean, st);
            }
        }
    } else if (name == "downsample-estimators") {
        const int sd = std::max(s.dims, 8);
        struct V {
            double voxels, steps;
            bool integer;
        };
        std::vector<V> vols = {{cube(std::ceil(sd / 4.0)), defaultSteps(sd, sd, sd), false}};
        for (const SharedVolume* v : {&kChest, &kNeghip, &kTooth})
            if (present(o, v->rel))
                vols.push_back(
                    {bricks(*v, 4), defaultSteps(v->nx, v->ny, v->nz, v->sx, v->sy, v->sz), true});
        for (const V& v : vols) {
            frame(K::Mean, v.steps);
            const DensityEstimate ests[] = {DensityEstimate::Empirical, DensityEstimate::Kde,
                                            DensityEstimate::Kde, DensityEstimate::Dequantized};
            for (DensityEstimate d : ests) {
                if (d == DensityEstimate::Dequantized && !v.integer) continue;
                w += buildWork(v.voxels, 64, d == DensityEstimate::Empirical ? 4 : 0, d, true);
                if (d == DensityEstimate::Empirical)
                    for (K k : {K::Mean, K::Gaussian, K::UniformFast, K::GmmOrdered})
                        frame(k, v.steps);
                for (K k : {K::QuantileRange, K::QuantileMean, K::Iqr}) frame(k, v.steps);
            }
        }
    }
    return w;
}

const Speed& machineSpeed() {
    static const Speed speed = [] {
        Speed s;
        const auto t0 = std::chrono::steady_clock::now();
        const ScalarField truth = makeTangle(16, 16, 16);
        NoiseParams noise;
        noise.seed = 1;
        const Ensemble e = perturbField(truth, 20, noise);
        BuildOptions bo;
        bo.quantiles = 8;
        bo.gmmComponents = 4;
        ModelVolume m;
        const double buildMs = probeMs([&] { m = buildModel(e, bo); });
        // One factor for both: a probe frame short enough to be cheap (a few ms) varied 3x
        // between runs under load, the build probe by 1.5x.
        s.build = s.frame = std::clamp(buildMs / kProbeBuildMs, 0.05, 50.0);
        s.probeSeconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        if (std::getenv("UDVR_EXPERIMENT_PROBE_LOG"))
            std::fprintf(stderr, "speed probe: build %.1f ms\n", buildMs);
        return s;
    }();
    return speed;
}

std::string estimateLine(const std::string& name, const ExperimentOptions& options) {
    const Sizes s = resolveSizes(name, options);
    const Work w = planExperiment(name, s, options);
    if (w.builds + w.frames == 0) return {};
    const Speed& speed = machineSpeed();
    const double ms = estimatedMs(w, speed);
    // For measuring the cost factors: the plan's parts, whatever their size.
    if (std::getenv("UDVR_EXPERIMENT_PROBE_LOG"))
        std::fprintf(stderr, "plan %s: builds %.0f ms, frames %.0f ms\n", name.c_str(),
                     w.buildMs * speed.build, w.frameMs * speed.frame);
    // UDVR_ANNOUNCE_OVER_MS: another threshold than kLongFrameMs (tests on fast machines; users
    // who want the line always: 0).
    const char* over = std::getenv("UDVR_ANNOUNCE_OVER_MS");
    const double threshold = over ? std::atof(over) : kLongFrameMs;
    if (ms <= threshold) return {};
    const auto secs = [](double v) { return fmt("%.0f s", v / 1000.0); };
    std::string line = "udvr experiment " + name + ": will take about " + secs(ms) + " (" +
                       std::to_string(w.builds) + " builds about " + secs(w.buildMs * speed.build) +
                       ", " + std::to_string(w.frames) + " frames of " + std::to_string(s.image) +
                       "x" + std::to_string(s.image) + " about " + secs(w.frameMs * speed.frame) +
                       "; a speed probe took " + fmt("%.2f", speed.probeSeconds) + " s); shorter:";
    std::vector<std::string> ways;
    if (!options.quick) {
        ExperimentOptions q = options;
        q.quick = true;
        ways.push_back("--quick (about " +
                       secs(estimatedMs(planExperiment(name, resolveSizes(name, q), q), speed)) +
                       ")");
    }
    if (s.image > 64) {
        ExperimentOptions q = options;
        q.imageSize = std::max(32, s.image / 4);
        ways.push_back("--size " + std::to_string(q.imageSize) + " (about " +
                       secs(estimatedMs(planExperiment(name, resolveSizes(name, q), q), speed)) +
                       ")");
    }
    if (ways.empty()) ways.push_back("nothing smaller here");
    for (std::size_t i = 0; i < ways.size(); ++i) line += (i ? " or " : " ") + ways[i];
    return line;
}

// ---- progress ----------------------------------------------------------------------------------

ExperimentProgress*& ExperimentProgress::current() {
    static thread_local ExperimentProgress* p = nullptr;
    return p;
}

ExperimentProgress::ExperimentProgress(std::string name, double plannedBuildMs,
                                       double plannedFrameMs, bool draw)
    : name_(std::move(name)), start_(std::chrono::steady_clock::now()) {
    plannedMs_[0] = plannedBuildMs, plannedMs_[1] = plannedFrameMs;
    if (!draw || !ProgressBar::enabled() || plannedBuildMs + plannedFrameMs <= 0.0) return;
    const auto every = std::chrono::duration<double>(ProgressBar::lineSeconds());
    ticker_ = std::thread([this, every] {
        std::unique_lock<std::mutex> lock(mutex_);
        while (!wake_.wait_for(lock, every, [this] { return stop_; })) {
            lock.unlock();
            const std::string l = line();
            std::fprintf(stderr, "%s\n", l.c_str());
            std::fflush(stderr);
            lock.lock();
        }
    });
}

ExperimentProgress::~ExperimentProgress() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stop_ = true;
    }
    wake_.notify_all();
    if (ticker_.joinable()) ticker_.join();
}

double ExperimentProgress::nowMs() const {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_)
        .count();
}

void ExperimentProgress::beginStage(double plannedMs, bool build) {
    std::lock_guard<std::mutex> lock(mutex_);
    inStage_ = true;
    stageType_ = build ? 0 : 1;
    stagePlannedMs_ = stageEstimateMs_ = plannedMs;
    begunPlannedMs_[stageType_] += plannedMs;
    stageStartMs_ = nowMs();
}

double ExperimentProgress::refineStage(double estimateMs) {
    std::lock_guard<std::mutex> lock(mutex_);
    // Within 5x of the plan: a frame's probes are closer than the plan as a rule, but a probe
    // too small to measure can be off by 100x.
    if (!inStage_ || estimateMs <= 0.0 || stagePlannedMs_ <= 0.0) return estimateMs;
    stageEstimateMs_ = std::clamp(estimateMs, stagePlannedMs_ / 5.0, stagePlannedMs_ * 5.0);
    return stageEstimateMs_;
}

void ExperimentProgress::endStage() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!inStage_) return;
    inStage_ = false;
    donePlannedMs_[stageType_] += stagePlannedMs_;
    doneActualMs_[stageType_] += nowMs() - stageStartMs_;
}

double ExperimentProgress::ratioLocked(int type) const {
    // How the stages of this type done so far compared with their plan (1 before any, or while
    // they are too short to say), within 1/3 … 3.
    return donePlannedMs_[type] > 50.0 && doneActualMs_[type] > 50.0
               ? std::clamp(doneActualMs_[type] / donePlannedMs_[type], 1.0 / 3.0, 3.0)
               : 1.0;
}

double ExperimentProgress::leftMsLocked(double now) const {
    double notBegun = 0.0;
    for (int t = 0; t < 2; ++t)
        notBegun += std::max(plannedMs_[t] - begunPlannedMs_[t], 0.0) * ratioLocked(t);
    if (!inStage_) return notBegun;
    // The running stage: its probes' estimate where there is one, else its plan × the ratio.
    const double stage = stageEstimateMs_ != stagePlannedMs_
                             ? stageEstimateMs_
                             : stagePlannedMs_ * ratioLocked(stageType_);
    // A stage past its estimate is taken to be four fifths done (its time so far / 4 left).
    const double inStage = now - stageStartMs_;
    return notBegun + (inStage < stage ? stage - inStage : 0.25 * inStage);
}

std::string ExperimentProgress::line() const {
    std::lock_guard<std::mutex> lock(mutex_);
    const double now = nowMs();
    const double left = leftMsLocked(now);
    // The share done is of the planned work (so it only grows, as a bar's units): the stages
    // ended, and the running one's plan by its time so far over its estimate (at most 95 %).
    double done = donePlannedMs_[0] + donePlannedMs_[1];
    if (inStage_)
        done += stagePlannedMs_ *
                std::min((now - stageStartMs_) / std::max(stageEstimateMs_, 1.0), 0.95);
    // Never below a share shown before (a frame's probes may raise its estimate as it starts).
    lastFrac_ = std::max(
        lastFrac_, std::min(done / std::max(plannedMs_[0] + plannedMs_[1], done + 1e-9), 1.0));
    const double frac = lastFrac_;
    char buf[160];
    std::snprintf(buf, sizeof buf, "experiment %s: %.0f %% done after %.0f s, about %.0f s left",
                  name_.c_str(), 100.0 * frac, now / 1000.0, left / 1000.0);
    return buf;
}

StageScope::StageScope(const Work& w) : p_(ExperimentProgress::current()) {
    if (p_) p_->beginStage(estimatedMs(w, machineSpeed()), w.builds > 0);
}
StageScope::~StageScope() {
    if (p_) p_->endStage();
}
double StageScope::refine(double estimateMs) {
    return p_ ? p_->refineStage(estimateMs) : estimateMs;
}

}  // namespace udvr::experiment_detail
