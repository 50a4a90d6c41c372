#include "udvr/eval/report.h"

#include <gtest/gtest.h>

namespace udvr {
namespace {

ResultRow row(const std::string& model, int q, double rmse, double ms = 10.0,
              const std::string& density = "", int members = 50) {
    ResultRow r;
    r.experiment = "test";
    r.model = model;
    r.label = model + (q > 0 ? " q=" + std::to_string(q) : "");
    r.quantiles = q;
    r.density = density.empty() && q > 0 ? "empirical" : density;
    r.members = members;
    r.rmse = rmse;
    r.renderMs = ms;
    return r;
}

TEST(Claims, TangleVerdictsFollowTheNumbers) {
    std::vector<ResultRow> rows = {row("ground-truth", 0, 0.0),
                                   row("mean", 0, 0.09),
                                   row("uniform", 0, 0.044, 100.0),
                                   row("gaussian", 0, 0.042, 50.0),
                                   row("quantile-range", 2, 0.055),
                                   row("quantile-range", 4, 0.043),
                                   row("quantile-range", 8, 0.038),
                                   row("quantile-mean", 2, 0.056),
                                   row("quantile-mean", 4, 0.039),
                                   row("quantile-mean", 8, 0.031, 150.0),
                                   row("iqr", 0, 0.025)};
    auto claims = checkClaims("tangle", rows);
    ASSERT_EQ(claims.size(), 5u);
    for (const ClaimCheck& c : claims) EXPECT_EQ(c.verdict, "holds") << c.claim << " " << c.detail;

    // Quantile-mean worse than gaussian: only quantile-range beats the parametric models; the
    // IQR is no longer the lowest; quantile-mean 3× slower than the slower parametric model.
    rows[9].rmse = 0.05;
    rows[9].renderMs = 300.0;
    rows[10].rmse = 0.1;
    claims = checkClaims("tangle", rows);
    EXPECT_EQ(claims[0].verdict, "partly holds");
    EXPECT_EQ(claims[2].verdict, "does not hold");
    EXPECT_NE(claims[2].detail.find("quantile-range q=8"), std::string::npos);
    EXPECT_EQ(claims[3].verdict, "does not hold");
}

TEST(Claims, MissingModelsAreNotMeasured) {
    const auto claims = checkClaims("tangle", {row("ground-truth", 0, 0.0), row("mean", 0, 0.1)});
    ASSERT_FALSE(claims.empty());
    EXPECT_EQ(claims[0].verdict, "not measured");
}

TEST(Claims, SweepComparesQuantileCountsPerMemberCount) {
    std::vector<ResultRow> rows;
    for (const char* d : {"empirical", "kde"})
        for (const char* m : {"quantile-range", "quantile-mean"}) {
            // 5 members: more quantiles hurt; 50 members: they help.
            rows.push_back(row(m, 2, 0.04, 1, d, 5));
            rows.push_back(row(m, 4, 0.05, 1, d, 5));
            rows.push_back(row(m, 8, 0.06, 1, d, 5));
            rows.push_back(row(m, 2, 0.05, 1, d, 50));
            rows.push_back(row(m, 4, 0.04, 1, d, 50));
            rows.push_back(row(m, 8, 0.03, 1, d, 50));
        }
    const auto claims = checkClaims("tangle-sweep", rows);
    ASSERT_EQ(claims.size(), 3u);
    EXPECT_EQ(claims[0].verdict, "holds");
    EXPECT_EQ(claims[1].verdict, "holds");
    EXPECT_EQ(claims[2].verdict, "measured");
}

TEST(Report, TableAndClaimsAppear) {
    ExperimentResult r;
    r.name = "tangle";
    r.rows = {row("ground-truth", 0, 0.0), row("quantile|mean", 8, 0.03125)};
    r.claims = {{"a claim", "holds", "numbers"}};
    r.files = {"figure.png"};
    const std::string md = experimentReport(r, "Title", {"setup line"}, {"figure.png"});
    EXPECT_NE(md.find("# Title"), std::string::npos);
    EXPECT_NE(md.find("- setup line"), std::string::npos);
    EXPECT_NE(md.find("![figure.png](figure.png)"), std::string::npos);
    EXPECT_NE(md.find("quantile\\|mean"), std::string::npos);  // pipes escaped in cells
    EXPECT_NE(md.find("0.03125"), std::string::npos);
    EXPECT_NE(md.find("**holds** — a claim. numbers."), std::string::npos);
}

}  // namespace
}  // namespace udvr
