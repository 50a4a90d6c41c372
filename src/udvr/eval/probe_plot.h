#pragma once
// The PDF at a probed point (as the paper's Fig. 2) above the transfer function, rasterized.
#include "udvr/classify/probe.h"
#include "udvr/io/image.h"

namespace udvr {

/// Plot of r.distribution over [lo, hi]: the continuous density (blue, normalised to its peak),
/// point masses as red spikes (height ∝ probability, the largest at full height), and beneath
/// it the TF's colour with its opacity curve (black) over the same x range; both panels with
/// ticks and labelled axes. At least 200 × 150 pixels.
ImageRgba renderProbePlot(const ProbeResult& r, const TransferFunction1D& tf, int width = 640,
                          int height = 480);

}  // namespace udvr
