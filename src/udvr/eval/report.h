#pragma once
// The experiments' Markdown reports and the check of the paper's claims against a run's table
// (printed, never asserted: a claim that does not hold here is a finding, not a failure).
#include <string>
#include <vector>

#include "udvr/eval/experiments.h"

namespace udvr {

/// The paper's claims that experiment `name` can speak to, judged on its rows.
std::vector<ClaimCheck> checkClaims(const std::string& name, const std::vector<ResultRow>& rows);

/// A Markdown table of the rows (label, model, q, density, members, RMSE, ms, memory, image).
std::string resultsMarkdownTable(const std::vector<ResultRow>& rows);

/// A section of a report after its table: a title and Markdown text.
struct ReportSection {
    std::string title;
    std::string markdown;
};

/// The report of one experiment: title, setup lines, figures, table, sections, claims, files.
std::string experimentReport(const ExperimentResult& result, const std::string& title,
                             const std::vector<std::string>& setup,
                             const std::vector<std::string>& figures,
                             const std::vector<ReportSection>& sections = {});

/// The summary of an `all` run: each experiment's claims and a link to its report.
std::string summaryReport(const std::vector<ExperimentResult>& results,
                          const std::vector<std::string>& skipped);

}  // namespace udvr
