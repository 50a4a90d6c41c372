// udvr experiment (SPEC §8): parse, run the library's experiment, print where the results are.
#include <cstdio>
#include <memory>
#include <string>

#include "udvr/cmd/commands.h"
#include "udvr/eval/experiments.h"
#include "udvr/util/check.h"

namespace udvr::cmd {

void addExperimentCommand(CLI::App& app) {
    auto* sub = app.add_subcommand(
        "experiment",
        "run one of the paper's experiments (figure, report, CSV/JSON table, images)");
    struct Args {
        std::string name;
        std::string out;
        bool quick = false;
        int size = 0;
        std::string tfDir, dataDir;
    };
    auto args = std::make_shared<Args>();
    std::string names;
    for (const std::string& n : experimentNames()) names += n + "|";
    sub->add_option("name", args->name, "experiment: " + names + "all")->required();
    sub->add_option("-o,--output", args->out, "output directory (created)")->required();
    sub->add_flag("--quick", args->quick,
                  "smaller grids, images and realization counts (the whole set in minutes)");
    sub->add_option("--size", args->size,
                    "square images of N pixels a side, at most the run's own (512, or --quick's); "
                    "shortens the frames");
    sub->add_option("--tf-dir", args->tfDir,
                    "folder of the transfer functions (default: the repository's data/tf)");
    sub->add_option("--data-dir", args->dataDir,
                    "folder of the real data sets (default: ../shared/data)");
    sub->callback([args] {
        ExperimentOptions o;
        o.quick = args->quick;
        if (args->size != 0 && (args->size < 8 || args->size > 4096))
            UDVR_FAIL("--size " << args->size
                                << " is out of range (8 to the run's own image size)");
        o.imageSize = args->size;
        o.tfDir = args->tfDir;
        o.dataDir = args->dataDir;
        const auto results = runExperiments(args->name, args->out, o);
        for (const ExperimentResult& r : results)
            std::printf("%s: %s/report.md (%.1f s)\n", r.name.c_str(), r.dir.string().c_str(),
                        r.seconds);
    });
}

}  // namespace udvr::cmd
