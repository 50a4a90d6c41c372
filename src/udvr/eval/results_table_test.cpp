#include "udvr/eval/results_table.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>

#include "udvr/classify/model_kind.h"
#include "udvr/util/check.h"

namespace udvr {
namespace {

std::vector<ResultRow> sampleRows() {
    std::vector<ResultRow> rows;
    ResultRow a;
    a.experiment = "tangle";
    a.label = "ground truth";
    a.model = "ground-truth";
    a.members = 1;
    a.rmse = 0.0;
    a.renderMs = 12.25;
    a.memoryRatio = 1.0;
    a.image = "images/ground-truth.png";
    rows.push_back(a);
    ResultRow b;
    b.experiment = "tangle";
    b.label = "quantile-mean q=8, \"kde\", 5 members";  // commas and quotes get quoted
    b.model = "quantile-mean";
    b.quantiles = 8;
    b.density = "kde";
    b.members = 5;
    b.rmse = 0.1 + 1e-17;
    b.renderMs = 1.0 / 3.0;
    b.memoryRatio = 9;
    b.image = "images/qm.png";
    rows.push_back(b);
    ResultRow c = b;
    c.label = "gmm-mc";
    c.model = "gmm-mc";
    c.quantiles = 0;
    c.gmmComponents = 4;
    c.density = "";
    c.rmse = std::nan("");
    c.memoryRatio = 12;
    rows.push_back(c);
    return rows;
}

void expectSame(const std::vector<ResultRow>& a, const std::vector<ResultRow>& b) {
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
        EXPECT_EQ(a[i].experiment, b[i].experiment);
        EXPECT_EQ(a[i].label, b[i].label);
        EXPECT_EQ(a[i].model, b[i].model);
        EXPECT_EQ(a[i].quantiles, b[i].quantiles);
        EXPECT_EQ(a[i].gmmComponents, b[i].gmmComponents);
        EXPECT_EQ(a[i].density, b[i].density);
        EXPECT_EQ(a[i].members, b[i].members);
        if (std::isnan(a[i].rmse))
            EXPECT_TRUE(std::isnan(b[i].rmse));
        else
            EXPECT_EQ(a[i].rmse, b[i].rmse);  // exact: printed with 17 digits
        EXPECT_EQ(a[i].renderMs, b[i].renderMs);
        EXPECT_EQ(a[i].memoryRatio, b[i].memoryRatio);
        EXPECT_EQ(a[i].image, b[i].image);
    }
}

TEST(ResultsTable, CsvRoundTrips) {
    const auto rows = sampleRows();
    const std::string csv = resultsToCsv(rows);
    EXPECT_EQ(csv.substr(0, csv.find('\n')),
              "experiment,label,model,q,gmm_k,density,members,rmse,render_ms,memory_ratio,image,"
              "rmse_members");
    expectSame(rows, resultsFromCsv(csv));
}

TEST(ResultsTable, JsonRoundTrips) {
    const auto rows = sampleRows();
    expectSame(rows, resultsFromJson(resultsToJson(rows)));
}

TEST(ResultsTable, FilesRoundTrip) {
    const auto dir = std::filesystem::temp_directory_path() /
                     ("udvr_results_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const auto rows = sampleRows();
    writeResultsCsv(dir / "r.csv", rows);
    writeResultsJson(dir / "r.json", rows);
    expectSame(rows, readResultsCsv(dir / "r.csv"));
    expectSame(rows, readResultsJson(dir / "r.json"));
    std::filesystem::remove_all(dir);
}

TEST(ResultsTable, BadInputThrows) {
    EXPECT_THROW(resultsFromCsv(""), UdvrError);
    EXPECT_THROW(resultsFromCsv("experiment,label\nx,y\n"), UdvrError);
    std::string csv = resultsToCsv(sampleRows());
    EXPECT_THROW(resultsFromCsv(csv + "tangle,x\n"), UdvrError);
    EXPECT_THROW(resultsFromJson("{"), UdvrError);
    EXPECT_THROW(resultsFromJson("{\"a\": 1}"), UdvrError);
    EXPECT_THROW(resultsFromJson("[{\"experiment\": \"x\"}]"), UdvrError);
}

TEST(ResultsTable, MemoryRatioFormula) {
    // The paper's §5 accounting: mean 1, uniform/gaussian 2, GMM 3K, quantiles q+1, IQR 2.
    EXPECT_EQ(memoryRatio(ModelKind::Mean, 8, 4), 1.0);
    EXPECT_EQ(memoryRatio(ModelKind::Uniform, 8, 4), 2.0);
    EXPECT_EQ(memoryRatio(ModelKind::Gaussian, 8, 4), 2.0);
    EXPECT_EQ(memoryRatio(ModelKind::GmmOrdered, 8, 4), 12.0);
    EXPECT_EQ(memoryRatio(ModelKind::GmmMc, 8, 3), 9.0);
    for (int q : {2, 4, 8}) {
        EXPECT_EQ(memoryRatio(ModelKind::QuantileRange, q, 4), q + 1.0);
        EXPECT_EQ(memoryRatio(ModelKind::QuantileMean, q, 4), q + 1.0);
        EXPECT_EQ(memoryRatio(ModelKind::QuantileMeanMass, q, 4), q + 1.0);
        EXPECT_EQ(memoryRatio(ModelKind::QuartileLower, q, 4), q + 1.0);
    }
    EXPECT_EQ(memoryRatio(ModelKind::Iqr, 8, 4), 2.0);
    EXPECT_EQ(memoryRatio(ModelKind::Members, 8, 4, 50), 50.0);  // the ensemble itself
    for (ModelKind k : allModelKinds()) EXPECT_GT(memoryRatio(k, 8, 4, 50), 0.0);
}

}  // namespace
}  // namespace udvr
