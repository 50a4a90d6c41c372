#pragma once
// A frame's time estimated before it is rendered (issue 35: cost before work), from short
// probes of the same model, TF and camera at a fraction of the size: `udvr render` warns before a
// long frame, `udvr serve` marks the models over its latency goal and renders them progressively.
#include <functional>

#include "udvr/render/render.h"

namespace udvr {

/// Frames estimated over this (ms) are announced before they start, with what would shorten
/// them (`udvr render`, `udvr experiment`).
inline constexpr double kLongFrameMs = 10'000.0;

struct FrameEstimate {
    double ms = 0.0;            // the estimated frame time (0: not estimated)
    int width = 0, height = 0;  // the last probe's size
    double probeMs = 0.0;       // the probes' time in all
    /// The deadline stopped a probe: the frame takes at least `ms` (that probe's time so far,
    /// times gmm-mc's realization ratio), likely much more.
    bool lowerBound = false;
};

struct FrameEstimateLimits {
    /// No probe that would take longer (the next probe is 4× the last one's pixels).
    double maxProbeMs = 1000.0;
    /// The probes' wall time in all (0: none): past it the running probe is cancelled and the
    /// estimate is a lower bound. Bounds the probes' cost whatever the model (serve).
    double deadlineMs = 0.0;
};

/// A 2x2 warm-up frame (not fitted: it builds what later frames reuse), then probes of frame `s`
/// at 1/32 of its size along each axis (at least 2 pixels), then twice and
/// four times that, stopping before a probe over limits.maxProbeMs (and before one as large as
/// the frame); the time fitted as a + b·pixels (a, b >= 0, least squares over the probes; a:
/// what a frame costs whatever its size, e.g. drawing a gmm-mc realization's voxels), or
/// where only the first fits, the line through it and a 2x2 probe (what a frame costs at any
/// size).
/// `monteCarlo` (gmm-mc): a 2x2 probe first where the 1/32 probes have 64 pixels or more (its
/// time: what drawing the realizations costs at any size; if no larger probe fits the limit,
/// the estimate is its time, a lower bound); the probes draw 4 realizations and the time scales
/// by the frame's count. The first probe (unless over maxProbeMs) and any under a
/// quarter of it run twice and keep the faster run (the first run builds the tables the frame
/// reuses; load only adds time). `probe` renders the settings it is given and returns the frame's
/// milliseconds (it throws RenderCancelled when their cancel flag turns true). No probe (ms 0)
/// where none is smaller than the frame. A RenderCancelled from s.cancel (not the deadline) passes
/// through.
FrameEstimate estimateFrame(const RenderSettings& s, bool monteCarlo,
                            const std::function<double(const RenderSettings&)>& probe,
                            const FrameEstimateLimits& limits = {});

}  // namespace udvr
