// udvr compare model.png truth.png [--diff diff.png]   — prints the RMSE of SPEC §6
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>

#include "udvr/cmd/commands.h"
#include "udvr/cmd/parse_util.h"
#include "udvr/eval/figure.h"
#include "udvr/eval/image_metrics.h"
#include "udvr/io/image.h"
#include "udvr/util/check.h"

namespace udvr::cmd {

namespace {

/// The value of `key` in a PNG's text chunks ("" when absent or not a PNG).
std::string settingOf(const PngText& text, const char* key) {
    for (const auto& [k, v] : text)
        if (k == key) return v;
    return "";
}

/// Refuse (or, with --force, warn about) two images whose recorded TF, camera or size differ
/// (`udvr render` records them as PNG text; images without them are compared as they are).
void requireSameSettings(const std::string& a, const std::string& b, bool force) {
    const auto textOf = [](const std::string& path) {
        std::string ext = std::filesystem::path(path).extension().string();
        for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        return ext == ".png" ? readPngText(path) : PngText{};
    };
    const PngText ta = textOf(a), tb = textOf(b);
    std::string differ, detail;
    const struct {
        const char* key;
        const char* what;
    } checks[] = {
        {"udvr:tf", "transfer functions"}, {"udvr:camera", "cameras"}, {"udvr:size", "sizes"}};
    for (const auto& c : checks) {
        const std::string va = settingOf(ta, c.key), vb = settingOf(tb, c.key);
        if (va.empty() || vb.empty() || va == vb) continue;
        differ += std::string(differ.empty() ? "" : ", ") + c.what;
        const bool tf = std::string(c.key) == "udvr:tf";
        const std::string sa = tf ? settingOf(ta, "udvr:tf-range") : va;
        const std::string sb = tf ? settingOf(tb, "udvr:tf-range") : vb;
        if (!sa.empty() && !sb.empty() && sa != sb)
            detail += std::string(detail.empty() ? "" : "; ") + (tf ? "TF range " : "") + sa +
                      " vs " + sb;
    }
    if (differ.empty()) return;
    std::ostringstream m;
    m << a << " and " << b << " were rendered with different " << differ
      << (detail.empty() ? "" : " (" + detail + ")")
      << ", so their RMSE measures that too: render both with the same --tf, camera and --size";
    if (!force) UDVR_FAIL(m.str() << ", or add --force to compare them anyway");
    std::fprintf(stderr, "compare: warning: %s\n", m.str().c_str());
}

}  // namespace

void addCompareCommand(CLI::App& app) {
    auto* sub = app.add_subcommand(
        "compare", "print the RMSE between a model image and the ground truth (SPEC §6)");
    struct Opts {
        std::string model, truth, diff;
        double maxDiff = 0.0;
        bool force = false;
    };
    auto o = std::make_shared<Opts>();
    sub->add_option("model", o->model, "model image (.png, .npy or .pfm)")->required();
    sub->add_option("truth", o->truth, "ground-truth image (.png, .npy or .pfm)")->required();
    sub->add_option("--diff", o->diff,
                    "write the blue-yellow difference image (PNG) with its colour scale (|d| of "
                    "SPEC 6) to the right");
    sub->add_option("--diff-max", o->maxDiff,
                    "difference mapped to full yellow (default: the image's largest)");
    sub->add_flag("--force", o->force,
                  "compare images that `udvr render` made with different TFs, cameras or sizes "
                  "(a warning instead of an error)");
    sub->callback([o] {
        if (!o->diff.empty()) {
            requireOutputExtension(o->diff, "--diff", {".png"}, "");
            requireOutputsNotInputs({{"--diff", o->diff}}, {o->model, o->truth});
            requireOutputDirectory(o->diff, "--diff");
        }
        const ImageRgba a = readImage(o->model);
        const ImageRgba b = readImage(o->truth);
        requireSameSettings(o->model, o->truth, o->force);
        const double rmse = imageRmse(a, b);  // throws on a size mismatch
        if (!o->diff.empty()) {
            // The map's top is --diff-max or the largest difference: the scale says which.
            double top = o->maxDiff;
            if (!(top > 0.0))
                for (float d : pixelDifferences(a, b)) top = std::max(top, static_cast<double>(d));
            writePng(o->diff, withDifferenceScale(differenceImage(a, b, o->maxDiff), top, "|d|"));
        }
        std::printf("%.8f\n", rmse);
    });
}

}  // namespace udvr::cmd
