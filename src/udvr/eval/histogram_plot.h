#pragma once
// A volume's value histogram as a figure (`udvr info --histogram`), optionally with a 1D TF
// over it as ParaView's colour-map editor draws one: colour strip and opacity curve.
#include <string>

#include "udvr/classify/transfer_function.h"
#include "udvr/io/image.h"
#include "udvr/stats/value_summary.h"

namespace udvr {

struct HistogramPlotOptions {
    int width = 720, height = 420;  // pixels of the whole figure
    bool logScale = false;          // bar height log10(1 + count) instead of count
    std::string title;              // drawn above the plot when not empty
    std::string xLabel = "value";
};

/// Bars of h.counts over [h.lo, h.hi] with ticks and labels; with `tf`, a strip of its colour
/// along the top of the plot and its opacity as a curve scaled to the plot's height (the
/// largest α printed). Opaque.
ImageRgba renderHistogramPlot(const Histogram& h, const TransferFunction1D* tf,
                              const HistogramPlotOptions& options = {});

}  // namespace udvr
