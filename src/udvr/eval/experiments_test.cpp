#include "udvr/eval/experiments.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "udvr/classify/model_kind.h"
#include "udvr/io/image.h"
#include "udvr/util/check.h"

namespace udvr {
namespace {

namespace fs = std::filesystem;

fs::path freshDir(const std::string& name) {
    const fs::path dir = fs::temp_directory_path() /
                         ("udvr_experiment_test_" + name + "_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    return dir;
}

std::string readText(const fs::path& p) {
    std::ifstream in(p);
    std::ostringstream os;
    os << in.rdbuf();
    return os.str();
}

/// A tiny configuration: every experiment but the chest in a few seconds.
ExperimentOptions tinyOptions(const fs::path& dir) {
    ExperimentOptions o;
    o.quick = true;
    o.dims = 24;
    o.members = 10;
    o.imageSize = 48;
    o.realizations = 4;
    o.sweepMembers = {5, 10};
    o.log = false;
    o.dataDir = dir / "no-such-data";  // the chest is skipped under `all`
    return o;
}

void expectPromisedFiles(const ExperimentResult& r) {
    for (const char* f : {"figure.png", "report.md", "results.csv", "results.json"})
        EXPECT_TRUE(fs::is_regular_file(r.dir / f)) << r.name << ": " << f;
    for (const fs::path& f : r.files) EXPECT_TRUE(fs::is_regular_file(r.dir / f)) << f;
    for (const ResultRow& row : r.rows) {
        EXPECT_TRUE(fs::is_regular_file(r.dir / row.image)) << row.image;
        EXPECT_EQ(row.experiment, r.name);
    }
    // The tables on disk are the table in memory.
    const auto csv = readResultsCsv(r.dir / "results.csv");
    const auto json = readResultsJson(r.dir / "results.json");
    ASSERT_EQ(csv.size(), r.rows.size());
    ASSERT_EQ(json.size(), r.rows.size());
    for (std::size_t i = 0; i < r.rows.size(); ++i) {
        EXPECT_EQ(csv[i].label, r.rows[i].label);
        EXPECT_EQ(json[i].rmse, r.rows[i].rmse);
    }
    // The report carries the table and the claims.
    const std::string report = readText(r.dir / "report.md");
    EXPECT_NE(report.find("| image | model |"), std::string::npos);
    if (!r.claims.empty()) {
        EXPECT_NE(report.find(r.claims.front().verdict), std::string::npos);
    }
}

TEST(Experiments, TinyAllRunsEndToEnd) {
    const fs::path dir = freshDir("all");
    const ExperimentOptions o = tinyOptions(dir);
    const auto results = runExperiments("all", dir, o);
    // No chest, tooth or Isabel data here.
    ASSERT_EQ(results.size(), experimentNames().size() - 3);
    EXPECT_TRUE(fs::is_regular_file(dir / "report.md"));
    for (const char* skipped : {"skipped: chest", "tooth2d (no data", "fiber-isabel (no data"})
        EXPECT_NE(readText(dir / "report.md").find(skipped), std::string::npos) << skipped;
    for (const ExperimentResult& r : results) {
        SCOPED_TRACE(r.name);
        EXPECT_EQ(r.dir, dir / r.name);
        expectPromisedFiles(r);
        ASSERT_FALSE(r.rows.empty());
        EXPECT_EQ(r.rows.front().model, "ground-truth");
        EXPECT_EQ(r.rows.front().rmse, 0.0);  // the truth against itself
        for (const ResultRow& row : r.rows) {
            EXPECT_TRUE(std::isfinite(row.rmse)) << row.label;
            EXPECT_GE(row.rmse, 0.0);
            EXPECT_GE(row.renderMs, 0.0);
            if (row.model != "ground-truth") {
                // The memory column is the formula of the paper's §5.
                EXPECT_EQ(row.memoryRatio, memoryRatio(parseModelKind(row.model), row.quantiles,
                                                       row.gmmComponents, row.members))
                    << row.label;
            }
        }
    }

    // The tangle (Fig. 4): every model, q = 2, 4, 8, difference images, positive errors.
    const ExperimentResult& t = results.front();
    ASSERT_EQ(t.name, "tangle");
    std::vector<std::string> labels;
    for (const ResultRow& row : t.rows) labels.push_back(row.label);
    for (const char* want : {"ground truth", "mean", "uniform", "gaussian", "gmm-mc", "gmm-ordered",
                             "quantile-range q=2", "quantile-range q=4", "quantile-range q=8",
                             "quantile-mean q=2", "quantile-mean q=4", "quantile-mean q=8", "iqr"})
        EXPECT_NE(std::find(labels.begin(), labels.end(), want), labels.end()) << want;
    for (const ResultRow& row : t.rows) {
        if (row.model == "ground-truth") continue;
        EXPECT_GT(row.rmse, 0.0) << row.label;  // noisy models differ from the truth
        EXPECT_EQ(row.members, 10);
        const fs::path diff = t.dir / (row.image.substr(0, row.image.size() - 4) + "-diff.png");
        EXPECT_TRUE(fs::is_regular_file(diff)) << diff;
        const ImageRgba img = readPng(t.dir / row.image);
        EXPECT_EQ(img.width, 48);
        EXPECT_EQ(img.height, 48);
    }
    EXPECT_TRUE(fs::is_regular_file(t.dir / "tf.json"));
    EXPECT_FALSE(t.claims.empty());

    // The sweep: both densities, q = 2, 4, 8, each member count.
    const ExperimentResult& s = results[1];
    ASSERT_EQ(s.name, "tangle-sweep");
    int quantileRows = 0;
    for (const ResultRow& row : s.rows)
        if (row.quantiles > 0) ++quantileRows;
    EXPECT_EQ(quantileRows, 2 /*densities*/ * 3 /*q*/ * 2 /*members*/ * 2 /*QR, QM*/);

    // Uneven quantile levels: tangle (with its members image) and spheres (no chest here), a
    // truth and QR, QM at three level sets each; the levels change the images; the tangle's
    // rows are compared with its members image, the spheres' (bricks) with none; one verdict
    // per dataset and model.
    const auto ql = std::find_if(results.begin(), results.end(), [](const ExperimentResult& r) {
        return r.name == "quantile-levels";
    });
    ASSERT_NE(ql, results.end());
    ASSERT_EQ(ql->rows.size(), 8u + 7u);
    EXPECT_EQ(ql->rows[0].model, "ground-truth");
    EXPECT_EQ(ql->rows[1].model, "members");
    EXPECT_EQ(ql->rows[8].model, "ground-truth");
    for (const std::size_t first : {std::size_t{2}, std::size_t{9}}) {
        const ResultRow* rows = &ql->rows[first];
        for (int i = 0; i < 6; ++i) {
            EXPECT_EQ(rows[i].quantiles, 8) << rows[i].label;
            EXPECT_EQ(std::isnan(rows[i].rmseMembers), first == 9) << rows[i].label;
        }
        EXPECT_NE(rows[1].rmse, rows[3].rmse) << "QM even vs tail-heavy: " << rows[1].label;
    }
    EXPECT_EQ(ql->claims.size(), 4u);
    fs::remove_all(dir);
}

// downsample-estimators at a tiny size: the spheres always, and chest, neghip and tooth where the
// shared data are present (skipped with a setup line otherwise). Per volume: the truth, the four
// estimator-free references once, and quantile-range, quantile-mean and iqr per estimator —
// dequantized only for the integer-typed (uint8) volumes; the table names the estimator; the
// rule's section and a claim per (volume, estimator) are in the report.
TEST(Experiments, DownsampleEstimatorsSmoke) {
    const fs::path dir = freshDir("downsample-estimators");
    ExperimentOptions o = tinyOptions(dir);
    o.dataDir = locateDataDir();  // empty without shared data: the spheres alone
    const auto results = runExperiments("downsample-estimators", dir, o);
    ASSERT_EQ(results.size(), 1u);
    const ExperimentResult& r = results.front();
    expectPromisedFiles(r);
    EXPECT_TRUE(fs::is_regular_file(dir / "estimators.md"));
    std::vector<std::string> volumes;
    std::map<std::string, int> quantileRows;  // volume → rows per estimator model
    std::string volume;
    for (const ResultRow& row : r.rows) {
        if (row.model == "ground-truth") {
            volume = row.label.substr(0, row.label.find(':'));
            volumes.push_back(volume);
            continue;
        }
        EXPECT_NE(row.label.find("(" + volume), std::string::npos) << row.label;
        if (row.density.empty()) continue;  // an estimator-free reference
        EXPECT_NE(row.label.find(", " + row.density + ")"), std::string::npos) << row.label;
        ++quantileRows[volume + " " + row.density];
    }
    ASSERT_FALSE(volumes.empty());
    EXPECT_EQ(volumes.front(), "spheres");
    for (const std::string& v : volumes)
        for (const char* est : {"empirical", "kde-silverman", "kde-scott", "dequantized"})
            EXPECT_EQ(quantileRows[v + " " + est],
                      std::string(est) == "dequantized" && v == "spheres" ? 0 : 3)
                << v << " " << est;
    const std::size_t perVolume = 1 + 4 + 3 * 3;
    const std::size_t integerVolumes = volumes.size() - 1;
    EXPECT_EQ(r.rows.size(), volumes.size() * perVolume + integerVolumes * 3);
    EXPECT_EQ(r.claims.size(), 3 + integerVolumes * 4);  // one per (volume, estimator)
    const std::string report = readText(dir / "report.md");
    EXPECT_NE(report.find("## Estimators and the default rule"), std::string::npos);
    EXPECT_NE(report.find("By this rule: **"), std::string::npos);
    fs::remove_all(dir);
}

TEST(Experiments, ChestWithoutDataIsAClearError) {
    const fs::path dir = freshDir("chest");
    ExperimentOptions o = tinyOptions(dir);
    try {
        runExperiments("chest", dir, o);
        FAIL() << "expected UdvrError";
    } catch (const UdvrError& e) {
        EXPECT_NE(std::string(e.what()).find("chest CT"), std::string::npos) << e.what();
    }
    fs::remove_all(dir);
}

// Fig. 11 on the analytic pair at the --quick size: the claims are measured, not assumed, and
// the run is deterministic, so both verdicts are regression checks.
TEST(Experiments, FiberKeepsTheSurfaceWholeWhereTheMeanBreaksIt) {
    const fs::path dir = freshDir("fiber");
    ExperimentOptions o;
    o.quick = true;
    o.log = false;
    const auto results = runExperiments("fiber", dir, o);
    ASSERT_EQ(results.size(), 1u);
    const ExperimentResult& r = results.front();
    expectPromisedFiles(r);
    EXPECT_TRUE(fs::is_regular_file(dir / "tf2.json"));
    EXPECT_TRUE(fs::is_regular_file(dir / "tf2.png"));
    ASSERT_EQ(r.rows.size(), 6u);  // truth, mean, uniform, gaussian, quantile-range, quantile-mean
    for (std::size_t i = 2; i < r.rows.size(); ++i) EXPECT_LT(r.rows[i].rmse, r.rows[1].rmse);
    ASSERT_EQ(r.claims.size(), 2u);
    for (const ClaimCheck& c : r.claims)
        EXPECT_EQ(c.verdict, "holds") << c.claim << ": " << c.detail;
    fs::remove_all(dir);
}

TEST(Experiments, FiberIsabelWithoutDataIsAClearError) {
    const fs::path dir = freshDir("fiber-isabel");
    ExperimentOptions o = tinyOptions(dir);
    try {
        runExperiments("fiber-isabel", dir, o);
        FAIL() << "expected UdvrError";
    } catch (const UdvrError& e) {
        EXPECT_NE(std::string(e.what()).find("windspeed_t02.vti"), std::string::npos) << e.what();
    }
    fs::remove_all(dir);
}

TEST(Experiments, UnknownNameIsAnError) {
    const fs::path dir = freshDir("unknown");
    EXPECT_THROW(runExperiments("fig99", dir, tinyOptions(dir)), UdvrError);
    fs::remove_all(dir);
}

TEST(Experiments, TransferFunctionsAreShipped) {
    const fs::path tf = locateTfDir();
    for (const char* f : {"tangle.json", "teardrop.json", "spheres.json", "chest-ct.json",
                          "neghip.json", "tooth.json"})
        EXPECT_TRUE(fs::is_regular_file(tf / f)) << f;
}

}  // namespace
}  // namespace udvr
