#pragma once
// The PDF at a probed point (as the paper's Fig. 2) above the transfer function, rasterized.
#include "udvr/classify/probe.h"
#include "udvr/io/image.h"

namespace udvr {

/// Plot of r.distribution over [lo, hi]: the continuous density (blue, normalised to its peak),
/// point masses as red spikes (height ∝ probability, the largest at full height), and beneath
/// it a strip with the TF colour and its opacity curve (black) over the same x range.
ImageRgba renderProbePlot(const ProbeResult& r, const TransferFunction1D& tf, int width = 640,
                          int height = 400);

}  // namespace udvr
