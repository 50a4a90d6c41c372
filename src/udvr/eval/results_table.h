#pragma once
// The table every experiment writes (CSV and JSON): one row per rendered image.
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "udvr/classify/model_kind.h"

namespace udvr {

struct ResultRow {
    std::string experiment;  // "tangle", "tangle-sweep", …
    std::string label;       // display label, e.g. "quantile-range q=8"
    std::string model;       // CLI model name, or "ground-truth"
    int quantiles = 0;       // q of the quantile representation (quantile models, iqr, quartiles)
    int gmmComponents = 0;   // K (gmm models), 0 otherwise
    std::string density;     // "empirical" or "kde" where quantiles are used, "" otherwise
    int members = 0;         // samples per voxel: ensemble members, or K³ for a brick
    double rmse = 0.0;       // SPEC §6 against the experiment's ground truth
    /// SPEC §6 against the ensemble's own expected image (model `members`) of an ensemble
    /// experiment; NaN where the experiment has none (or the row was rendered before it).
    double rmseMembers = std::numeric_limits<double>::quiet_NaN();
    double renderMs = 0.0;     // wall time of the frame (all realizations for gmm-mc)
    double memoryRatio = 0.0;  // stored values per voxel relative to the mean field
    std::string image;         // image file, relative to the experiment directory
};

/// Memory per voxel relative to the mean field (the paper's §5 accounting): mean 1, uniform and
/// gaussian 2 (μ, σ), gmm 3K (π, μ, σ per component), quantile models and quartile views q+1
/// (the boundaries b_0..b_q), iqr 2, the members reference n (its `members`).
double memoryRatio(ModelKind kind, int quantiles, int gmmComponents, int members = 0);

/// CSV with a header line (rmse_members last: tables written before it still read, as NaN);
/// fields quoted where they hold commas, quotes or newlines; numbers
/// printed to round-trip exactly.
std::string resultsToCsv(const std::vector<ResultRow>& rows);
/// Parse what resultsToCsv writes (columns matched by header name). Throws UdvrError.
std::vector<ResultRow> resultsFromCsv(const std::string& text);
/// JSON: a list of objects with the CSV's column names as keys.
std::string resultsToJson(const std::vector<ResultRow>& rows);
/// Parse what resultsToJson writes. Throws UdvrError.
std::vector<ResultRow> resultsFromJson(const std::string& text);

/// Write results.csv / results.json style files atomically.
void writeResultsCsv(const std::filesystem::path& path, const std::vector<ResultRow>& rows);
void writeResultsJson(const std::filesystem::path& path, const std::vector<ResultRow>& rows);
/// Read them back.
std::vector<ResultRow> readResultsCsv(const std::filesystem::path& path);
std::vector<ResultRow> readResultsJson(const std::filesystem::path& path);

}  // namespace udvr
