#pragma once
// The paper's experiments (Athawale et al. 2021, §5), end to end: make or read the data, build
// the models, render each with the same transfer function and camera as the ground truth, and
// write a figure panel, a Markdown report, a CSV/JSON table and the individual images.
//   tangle        Fig. 4   — 64³ tangle, 50 members, bimodal noise, every model, q = 2, 4, 8
//   tangle-sweep  Fig. 5a  — RMSE vs q × members, empirical and KDE quantiles
//   teardrop      teaser a — 64³ teardrop, 50 members
//   quartiles     Fig. 6   — quartile view of the tangle
//   spheres       Fig. 8   — nested spheres 512³ reduced by 4³ bricks
//   chest         teaser b / Fig. 9 — chest CT reduced by 4³ bricks (plays OBELIX)
//   downsample-estimators — issue 12.2: empirical, KDE and dequantised quantiles on bricks
#include <filesystem>
#include <string>
#include <vector>

#include "udvr/eval/results_table.h"

namespace udvr {

struct ExperimentOptions {
    bool quick = false;             // smaller grids, images and realization counts
    std::filesystem::path tfDir;    // transfer functions; empty = locateTfDir()
    std::filesystem::path dataDir;  // real data (chest-ct/…); empty = locateDataDir()
    // Size overrides for tests; 0 or empty = the experiment's own full or --quick value.
    int dims = 0;                   // synthetic grid points per axis (spheres: full resolution)
    int members = 0;                // ensemble members
    int imageSize = 0;              // square images, pixels per side
    int realizations = 0;           // gmm-mc realizations
    std::vector<int> sweepMembers;  // tangle-sweep member counts
    bool log = true;                // one line per step on stderr
};

/// One statement of the paper and what this run says about it.
struct ClaimCheck {
    std::string claim;    // the paper's statement, with its figure
    std::string verdict;  // "holds", "does not hold" or "not measured"
    std::string detail;   // the numbers behind the verdict
};

struct ExperimentResult {
    std::string name;
    std::filesystem::path dir;                 // where its files are
    std::vector<ResultRow> rows;               // also in results.csv / results.json
    std::vector<ClaimCheck> claims;            // also in report.md
    std::vector<std::filesystem::path> files;  // every file written, relative to dir
    double seconds = 0.0;                      // wall time of the whole experiment
};

/// The experiment names runExperiments accepts, besides "all".
const std::vector<std::string>& experimentNames();

/// Run experiment `name` into outDir (created), or "all": each experiment into outDir/NAME and
/// a summary report.md in outDir. Throws UdvrError for an unknown name or, for `chest`, when
/// the data are absent (under `all` the chest is skipped with a message instead).
std::vector<ExperimentResult> runExperiments(const std::string& name,
                                             const std::filesystem::path& outDir,
                                             const ExperimentOptions& options);

/// Where the shipped transfer functions (data/tf/*.json) are: $UDVR_TF_DIR, else data/tf beside
/// or above the executable, else the source tree's, else ./data/tf. Throws UdvrError if none.
std::filesystem::path locateTfDir();
/// Where the shared real data are: $UDVR_DATA_DIR, else ../shared/data from the executable, the
/// source tree or the working directory. Returns an empty path if none exists.
std::filesystem::path locateDataDir();

}  // namespace udvr
