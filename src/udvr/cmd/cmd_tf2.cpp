// udvr tf2 TF2FILE [--tf2-domain x0,x1,y0,y1] [--resolution WxH] [-o raster.vti|raster.npy]
//          [--volume FILE] [--png view.png] [--bins N|NXxNY] [--log]          (SPEC §8, §9)
// Reads a 2D transfer function in any form, optionally writes it as a raster, and draws it over
// the joint histogram of (value, gradient magnitude) of a volume's grid points.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "udvr/cmd/commands.h"
#include "udvr/cmd/parse_util.h"
#include "udvr/eval/figure.h"
#include "udvr/eval/tf2_plot.h"
#include "udvr/io/field_io.h"
#include "udvr/io/model_io.h"
#include "udvr/io/transfer_function_2d_io.h"
#include "udvr/reconstruct/gradient_field.h"
#include "udvr/util/check.h"

namespace udvr::cmd {
namespace {

struct Tf2Opts {
    Tf2Flags tf2;  // the file (positional), --tf2-domain, --resolution
    std::string out, volume, png, bins = "256", size = "720x600", var;
    bool log = false, force = false;
    RawLayoutFlags raw;  // headerless .raw volume
};

std::string formatRanges(const std::vector<std::pair<double, double>>& ranges) {
    if (ranges.empty()) return "none (alpha = 0 everywhere)";
    std::string out;
    char buf[96];
    for (const auto& [a, b] : ranges) {
        std::snprintf(buf, sizeof buf, "%s[%g, %g]", out.empty() ? "" : " ", a, b);
        out += buf;
    }
    return out;
}

void run(const Tf2Opts& o) {
    // Check every flag and output folder before reading anything.
    const Tf2ReadOptions ro = toTf2ReadOptions(o.tf2, o.force);
    if (!o.out.empty()) {
        const std::string e = lowerExtension(o.out);
        if (e != ".vti" && e != ".npy")
            UDVR_FAIL("-o must name a .vti or .npy file, got '" << o.out << "'");
        requireOutputDirectory(o.out, "-o");
    }
    if (!o.png.empty()) {
        if (lowerExtension(o.png) != ".png")
            UDVR_FAIL("--png must name a .png file, got '" << o.png << "'");
        requireOutputDirectory(o.png, "--png");
    }
    requireOutputsNotInputs({{"-o", o.out}, {"--png", o.png}}, {o.tf2.file, o.volume});
    const auto bins = parseSize(o.bins, "--bins");
    const auto size = parseSize(o.size, "--size");
    if (size[0] < 160 || size[1] < 120)
        UDVR_FAIL("--size must be at least 160x120, got '" << o.size << "'");

    const TransferFunction2D tf = readTransferFunction2D(o.tf2.file, ro);
    std::unique_ptr<JointHistogram> histogram;
    std::string volumeName;
    if (!o.volume.empty()) {
        // A model's `mean` array, or the field's values.
        const ModelVolume m = readModelOrField(o.volume, o.var, o.raw);
        volumeName = std::filesystem::path(o.volume).filename().string();
        const std::vector<float> g = gridGradientMagnitudes(m.grid, m.mean.data());
        histogram = std::make_unique<JointHistogram>(
            jointHistogram(m.mean, g, bins[0], bins[1], {tf.x0, tf.x1, tf.y0, tf.y1}));
    }
    if (!o.out.empty()) writeTransferFunction2D(o.out, tf);
    if (!o.png.empty()) {
        Tf2PlotOptions po;
        po.width = size[0];
        po.height = size[1];
        po.logScale = o.log;
        po.title = std::filesystem::path(o.tf2.file).filename().string();
        if (histogram) po.title += " over " + std::filesystem::path(o.volume).filename().string();
        writeFigurePng(o.png, renderTf2Plot(tf, histogram.get(), po));
    }

    float alphaMin = 1.f, alphaMax = 0.f;
    for (std::size_t k = 3; k < tf.rgba.size(); k += 4) {
        alphaMin = std::min(alphaMin, tf.rgba[k]);
        alphaMax = std::max(alphaMax, tf.rgba[k]);
    }
    std::printf(
        "tf2: %dx%d points, x [%g, %g], y [%g, %g], alpha [%g, %g], alpha > 0 for x in %s\n",
        tf.width, tf.height, tf.x0, tf.x1, tf.y0, tf.y1, alphaMin, alphaMax,
        formatRanges(tf.nonZeroOpacityXRanges()).c_str());
    if (histogram)
        std::printf(
            "histogram: %zu grid points of %s, value [%g, %g], gradient magnitude [%g, %g]; "
            "%zu outside the TF2's domain\n",
            histogram->total, volumeName.c_str(), histogram->xMin, histogram->xMax, histogram->yMin,
            histogram->yMax, histogram->outside);
}

}  // namespace

void addTf2Command(CLI::App& app) {
    auto* sub = app.add_subcommand(
        "tf2",
        "read a 2D transfer function (.vti, .npy or widget .json), write it as a raster, draw it "
        "over a volume's (value, gradient magnitude) histogram (SPEC §9)");
    auto o = std::make_shared<Tf2Opts>();
    sub->add_option("tf2", o->tf2.file,
                    "2D transfer function: raster .vti or .npy, or widget .json")
        ->required();
    sub->add_option("--tf2-domain", o->tf2.domain,
                    "x0,x1,y0,y1: the domain of a .npy raster (required there); overrides a "
                    ".json's");
    sub->add_option("--resolution,--tf2-resolution", o->tf2.resolution,
                    "widget .json: raster points WxH (default the file's, else 256x256)");
    sub->add_option("-o,--output", o->out, "write the raster (.vti or .npy by the extension)");
    sub->add_option("--volume,--over", o->volume,
                    "a field, or a model .vti (its mean), whose grid points make the histogram");
    sub->add_option("--var", o->var, "array/variable name in the volume");
    addRawLayoutOptions(sub, o->raw);
    sub->add_option("--png", o->png, "draw the TF2 (over the histogram with --volume) as PNG");
    sub->add_option("--size", o->size, "PNG size WxH (default 720x600)");
    sub->add_option("--bins", o->bins,
                    "histogram bins N or NXxNY over the TF2's domain (default 256)");
    sub->add_flag("--log", o->log, "grey level by log(1 + count) instead of count");
    sub->add_flag("--force", o->force,
                  "rasterise widgets even when that takes over 1e8 widget evaluations (points x "
                  "widgets, a band's segments each counting one)");
    sub->callback([o] { run(*o); });
}

}  // namespace udvr::cmd
