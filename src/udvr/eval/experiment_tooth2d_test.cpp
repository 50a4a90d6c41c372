// `udvr experiment tooth2d` (Fig. 10) in its --quick form on a small image: the files it
// promises, its table and its claims.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include "udvr/eval/experiments.h"
#include "udvr/eval/results_table.h"

namespace udvr {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
    std::ifstream in(p);
    std::ostringstream os;
    os << in.rdbuf();
    return os.str();
}

TEST(Tooth2d, QuickRunWritesItsFilesTableAndClaims) {
    ExperimentOptions o;
    o.quick = true;
    o.imageSize = 48;
    o.log = false;
    o.dataDir = locateDataDir();
    if (o.dataDir.empty() || !fs::exists(o.dataDir / "tooth" / "tooth.nhdr"))
        GTEST_SKIP() << "no tooth CT (tooth/tooth.nhdr under ../shared/data or UDVR_DATA_DIR)";

    const fs::path dir =
        fs::temp_directory_path() / ("udvr_tooth2d_test_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    const auto results = runExperiments("tooth2d", dir, o);
    ASSERT_EQ(results.size(), 1u);
    const ExperimentResult& r = results[0];
    EXPECT_EQ(r.name, "tooth2d");

    // The promised files, and every file and image the run lists.
    for (const char* f :
         {"figure.png", "tf2.png", "tf2.json", "report.md", "results.csv", "results.json"})
        EXPECT_TRUE(fs::is_regular_file(r.dir / f)) << f;
    for (const fs::path& f : r.files) EXPECT_TRUE(fs::is_regular_file(r.dir / f)) << f;
    EXPECT_EQ(readResultsCsv(r.dir / "results.csv").size(), r.rows.size());

    // The truth row first, RMSE 0; every model finite and above 0.
    ASSERT_FALSE(r.rows.empty());
    EXPECT_EQ(r.rows[0].model, "ground-truth");
    EXPECT_EQ(r.rows[0].rmse, 0.0);
    std::set<std::string> labels;
    for (std::size_t i = 1; i < r.rows.size(); ++i) {
        const ResultRow& row = r.rows[i];
        EXPECT_NE(row.model, "ground-truth");
        EXPECT_TRUE(std::isfinite(row.rmse)) << row.label;
        EXPECT_GT(row.rmse, 0.0) << row.label;
        EXPECT_TRUE(fs::is_regular_file(r.dir / row.image)) << row.image;
        labels.insert(row.label);
    }
    // Mean and quantile-mean for both reductions, the fast gaussian and uniform (issue 33); no
    // model without a 2D kernel, no exact reference.
    for (const char* l : {"mean, 4³", "mean, 2³", "quantile-mean q=8, 4³", "quantile-mean q=8, 2³",
                          "gaussian, 4³", "gaussian, 2³", "uniform, 4³", "uniform, 2³"})
        EXPECT_TRUE(labels.count(l)) << l;
    for (const ResultRow& row : r.rows) {
        EXPECT_NE(row.model, "uniform-exact");
        EXPECT_NE(row.model, "gaussian-exact");
        EXPECT_NE(row.model, "uniform-fast");
        EXPECT_NE(row.model, "gmm-mc");
        EXPECT_NE(row.model, "gmm-ordered");
    }

    // One claim per reduction with a verdict, and the report states them.
    ASSERT_EQ(r.claims.size(), 2u);
    const std::string report = slurp(r.dir / "report.md");
    for (const ClaimCheck& c : r.claims) {
        EXPECT_TRUE(c.verdict == "holds" || c.verdict == "does not hold") << c.verdict;
        EXPECT_NE(c.detail.find("RMSE mean"), std::string::npos) << c.detail;
        EXPECT_NE(report.find(c.claim), std::string::npos) << c.claim;
    }
    EXPECT_NE(report.find("not available with a 2D TF yet"), std::string::npos);
    EXPECT_NE(report.find("tf2.png"), std::string::npos);
    fs::remove_all(dir);
}

}  // namespace
}  // namespace udvr
