#pragma once
// Cost before work for `udvr experiment` (issue 35, eval/ internal): the whole run's time
// estimated before it starts, from the experiment's known work (builds: voxels × samples; frames:
// pixels × ray steps × a model's cost per sample) scaled by a short speed probe of this machine,
// and a progress line over the whole experiment with the time left, corrected as the stages end.
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "udvr/classify/model_kind.h"
#include "udvr/eval/experiments.h"
#include "udvr/stats/build_model.h"

namespace udvr::experiment_detail {

struct Sizes;

/// tooth2d: the models with a 2D (value × gradient magnitude) kernel that the experiment renders
/// (its plan below renders the same list), the gaussian and the paper's uniform in their fast
/// forms (`gaussian`: the prefiltered tables of expected_tf2_fast.h, within 3e−6 of
/// `gaussian-exact`; `uniform`: the evaluation by columns, within 1e−3 of `uniform-exact`, 6.2e−6
/// on the tooth at the experiment's raster; docs/models.md).
inline constexpr ModelKind kTooth2dModels[] = {ModelKind::Mean,         ModelKind::Gaussian,
                                               ModelKind::Uniform,      ModelKind::QuantileRange,
                                               ModelKind::QuantileMean, ModelKind::Iqr};

/// What one build or frame is expected to cost, in milliseconds at the reference speed (the
/// machine and load on which the cost factors of experiment_plan.cpp were measured).
struct Work {
    double buildMs = 0.0;
    double frameMs = 0.0;
    int builds = 0, frames = 0;
    Work& operator+=(const Work& o) {
        buildMs += o.buildMs, frameMs += o.frameMs, builds += o.builds, frames += o.frames;
        return *this;
    }
};

/// A build of `voxels` model voxels from `samples` values each (members, or a field's brick
/// points: `bricks`).
Work buildWork(double voxels, int samples, int gmmComponents, DensityEstimate density,
               bool bricks = false);
enum class TfKind { OneD, TwoD, Bivariate };

/// A frame of `pixels` pixels with `steps` ray steps across the volume's longest side (its
/// extent over the ray step), of model `kind` on `voxels` voxels (members: `members` of them;
/// gmm-mc: `realizations`, each drawn over the voxels), with a 1D or 2D TF or two fields.
Work frameWork(ModelKind kind, double pixels, double steps, double voxels, int realizations,
               int members, TfKind tf);

/// The work of experiment `name` at sizes `s` (the data it would read, from `options`).
Work planExperiment(const std::string& name, const Sizes& s, const ExperimentOptions& options);

/// This machine's speed now relative to the reference, as factors on build and frame times
/// (1: as fast; 2: twice as slow), from a short probe (a 16³ tangle of 20 members built with
/// q = 8 and K = 4; ~0.1 s), once per process; one factor for builds and frames alike.
struct Speed {
    double build = 1.0, frame = 1.0;
    double probeSeconds = 0.0;
};
const Speed& machineSpeed();

inline double estimatedMs(const Work& w, const Speed& speed) {
    return w.buildMs * speed.build + w.frameMs * speed.frame;
}

/// The one line before a run over the threshold (kLongFrameMs): the estimate, its parts and
/// what would shorten it (each with its own estimate). Empty when under it.
std::string estimateLine(const std::string& name, const ExperimentOptions& options);

/// Progress over a whole experiment: a line "experiment NAME: P % done after T s, about R s
/// left" every ProgressBar::lineSeconds() (10 s; UDVR_PROGRESS_EVERY), whether stderr is a
/// terminal or not; UDVR_NO_PROGRESS=1 silences it. The share done is of the planned work (it
/// only grows); the time left is the planned work not yet done, scaled by how long the stages
/// done so far took against their plan.
class ExperimentProgress {
  public:
    ExperimentProgress(std::string name, double plannedBuildMs, double plannedFrameMs, bool draw);
    ~ExperimentProgress();
    ExperimentProgress(const ExperimentProgress&) = delete;
    ExperimentProgress& operator=(const ExperimentProgress&) = delete;

    /// A build or frame starts: its planned ms (at this machine's speed).
    void beginStage(double plannedMs, bool build);
    /// A better estimate of the running stage (a frame's probes), ms; kept within 5x of the
    /// stage's plan, and returned so.
    double refineStage(double estimateMs);
    void endStage();
    /// The line as it would be printed now.
    std::string line() const;

    /// The experiment running on this thread (null: none), for Run's hooks.
    static ExperimentProgress*& current();

  private:
    double leftMsLocked(double nowMs) const;
    double nowMs() const;
    std::string name_;
    std::chrono::steady_clock::time_point start_;
    mutable std::mutex mutex_;
    std::condition_variable wake_;
    bool stop_ = false;
    // [0]: builds, [1]: frames, each corrected by its own ratio of time taken over plan.
    double plannedMs_[2] = {0, 0};                                 // the whole plan
    double begunPlannedMs_[2] = {0, 0};                            // plans of the stages begun
    double donePlannedMs_[2] = {0, 0}, doneActualMs_[2] = {0, 0};  // stages ended
    double ratioLocked(int type) const;
    mutable double lastFrac_ = 0.0;  // the share done last shown
    bool inStage_ = false;
    int stageType_ = 0;
    double stagePlannedMs_ = 0.0, stageEstimateMs_ = 0.0, stageStartMs_ = 0.0;
    std::thread ticker_;
};

/// Marks one stage for the current experiment's progress (if any) for its lifetime.
class StageScope {
  public:
    explicit StageScope(const Work& w);
    ~StageScope();
    /// The progress's refineStage (the estimate as given where no experiment is in progress).
    double refine(double estimateMs);
    StageScope(const StageScope&) = delete;
    StageScope& operator=(const StageScope&) = delete;

  private:
    ExperimentProgress* p_;
};

}  // namespace udvr::experiment_detail
