// udvr compare model.png truth.png [--diff diff.png]   — prints the RMSE of SPEC §6
#include <cstdio>
#include <memory>
#include <string>

#include "udvr/cmd/commands.h"
#include "udvr/cmd/parse_util.h"
#include "udvr/eval/image_metrics.h"
#include "udvr/io/image.h"

namespace udvr::cmd {

void addCompareCommand(CLI::App& app) {
    auto* sub = app.add_subcommand(
        "compare", "print the RMSE between a model image and the ground truth (SPEC §6)");
    struct Opts {
        std::string model, truth, diff;
        double maxDiff = 0.0;
    };
    auto o = std::make_shared<Opts>();
    sub->add_option("model", o->model, "model image (.png, .npy or .pfm)")->required();
    sub->add_option("truth", o->truth, "ground-truth image (.png, .npy or .pfm)")->required();
    sub->add_option("--diff", o->diff, "write the blue-yellow difference image (PNG)");
    sub->add_option("--diff-max", o->maxDiff,
                    "difference mapped to full yellow (default: the image's largest)");
    sub->callback([o] {
        if (!o->diff.empty()) {
            requireOutputExtension(o->diff, "--diff", {".png"}, "");
            requireOutputsNotInputs({{"--diff", o->diff}}, {o->model, o->truth});
            requireOutputDirectory(o->diff, "--diff");
        }
        const ImageRgba a = readImage(o->model);
        const ImageRgba b = readImage(o->truth);
        const double rmse = imageRmse(a, b);  // throws on a size mismatch
        if (!o->diff.empty()) writePng(o->diff, differenceImage(a, b, o->maxDiff));
        std::printf("%.8f\n", rmse);
    });
}

}  // namespace udvr::cmd
