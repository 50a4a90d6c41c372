#include "udvr/eval/results_table.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <locale>
#include <nlohmann/json.hpp>
#include <sstream>

#include "udvr/classify/model_families.h"
#include "udvr/util/atomic_file.h"
#include "udvr/util/check.h"

namespace udvr {
namespace {

const std::vector<std::string> kColumns = {"experiment", "label",        "model",   "q",
                                           "gmm_k",      "density",      "members", "rmse",
                                           "render_ms",  "memory_ratio", "image",   "rmse_members"};
// Columns a table may lack (written before they were added): read as NaN.
constexpr std::size_t kFirstOptionalColumn = 11;

std::string formatDouble(double v) {
    if (std::isnan(v)) return "nan";
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}

std::string csvField(const std::string& s) {
    if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
    std::string out = "\"";
    for (char c : s) {
        if (c == '"') out += '"';
        out += c;
    }
    return out + "\"";
}

/// Split CSV text into records of fields (RFC 4180 quoting).
std::vector<std::vector<std::string>> parseCsv(const std::string& text) {
    std::vector<std::vector<std::string>> records;
    std::vector<std::string> record;
    std::string field;
    bool quoted = false, any = false;
    for (std::size_t i = 0; i < text.size(); ++i) {
        const char c = text[i];
        if (quoted) {
            if (c == '"') {
                if (i + 1 < text.size() && text[i + 1] == '"') {
                    field += '"';
                    ++i;
                } else {
                    quoted = false;
                }
            } else {
                field += c;
            }
            continue;
        }
        if (c == '"') {
            quoted = true;
            any = true;
        } else if (c == ',') {
            record.push_back(field);
            field.clear();
            any = true;
        } else if (c == '\n' || c == '\r') {
            if (c == '\r' && i + 1 < text.size() && text[i + 1] == '\n') ++i;
            if (any || !field.empty()) {
                record.push_back(field);
                records.push_back(record);
            }
            record.clear();
            field.clear();
            any = false;
        } else {
            field += c;
            any = true;
        }
    }
    if (quoted) UDVR_FAIL("results CSV: unterminated quoted field");
    if (any || !field.empty()) {
        record.push_back(field);
        records.push_back(record);
    }
    return records;
}

double parseDouble(const std::string& s, const char* column) {
    if (s == "nan") return std::numeric_limits<double>::quiet_NaN();
    std::istringstream is(s);
    is.imbue(std::locale::classic());
    double v = 0;
    is >> v;
    if (is.fail() || !is.eof())
        UDVR_FAIL("results CSV: column '" << column << "': '" << s << "' is not a number");
    return v;
}

int parseInt(const std::string& s, const char* column) {
    int v = 0;
    const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || ptr != s.data() + s.size())
        UDVR_FAIL("results CSV: column '" << column << "': '" << s << "' is not an integer");
    return v;
}

std::string readText(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) UDVR_FAIL("cannot open " << path.string());
    std::ostringstream os;
    os << in.rdbuf();
    return os.str();
}

}  // namespace

double memoryRatio(ModelKind kind, int quantiles, int gmmComponents, int members) {
    return modelFamily(kind).floatsPerVoxel(quantiles, gmmComponents, members);
}

std::string resultsToCsv(const std::vector<ResultRow>& rows) {
    std::string out;
    for (std::size_t i = 0; i < kColumns.size(); ++i) out += (i ? "," : "") + kColumns[i];
    out += "\n";
    for (const ResultRow& r : rows) {
        const std::vector<std::string> f = {csvField(r.experiment),
                                            csvField(r.label),
                                            csvField(r.model),
                                            std::to_string(r.quantiles),
                                            std::to_string(r.gmmComponents),
                                            csvField(r.density),
                                            std::to_string(r.members),
                                            formatDouble(r.rmse),
                                            formatDouble(r.renderMs),
                                            formatDouble(r.memoryRatio),
                                            csvField(r.image),
                                            formatDouble(r.rmseMembers)};
        for (std::size_t i = 0; i < f.size(); ++i) out += (i ? "," : "") + f[i];
        out += "\n";
    }
    return out;
}

std::vector<ResultRow> resultsFromCsv(const std::string& text) {
    const auto records = parseCsv(text);
    if (records.empty()) UDVR_FAIL("results CSV: empty (expected a header line)");
    const auto& header = records.front();
    std::vector<int> col(kColumns.size(), -1);
    for (std::size_t c = 0; c < kColumns.size(); ++c)
        for (std::size_t h = 0; h < header.size(); ++h)
            if (header[h] == kColumns[c]) col[c] = static_cast<int>(h);
    for (std::size_t c = 0; c < kFirstOptionalColumn; ++c)
        if (col[c] < 0) UDVR_FAIL("results CSV: no column '" << kColumns[c] << "' in the header");
    std::vector<ResultRow> rows;
    for (std::size_t r = 1; r < records.size(); ++r) {
        const auto& rec = records[r];
        if (rec.size() != header.size())
            UDVR_FAIL("results CSV: line " << r + 1 << " has " << rec.size() << " fields, expected "
                                           << header.size());
        auto get = [&](std::size_t c) -> const std::string& {
            return rec[static_cast<std::size_t>(col[c])];
        };
        ResultRow row;
        row.experiment = get(0);
        row.label = get(1);
        row.model = get(2);
        row.quantiles = parseInt(get(3), "q");
        row.gmmComponents = parseInt(get(4), "gmm_k");
        row.density = get(5);
        row.members = parseInt(get(6), "members");
        row.rmse = parseDouble(get(7), "rmse");
        row.renderMs = parseDouble(get(8), "render_ms");
        row.memoryRatio = parseDouble(get(9), "memory_ratio");
        row.image = get(10);
        if (col[11] >= 0) row.rmseMembers = parseDouble(get(11), "rmse_members");
        rows.push_back(std::move(row));
    }
    return rows;
}

std::string resultsToJson(const std::vector<ResultRow>& rows) {
    nlohmann::ordered_json list = nlohmann::ordered_json::array();
    for (const ResultRow& r : rows) {
        nlohmann::ordered_json o;
        o["experiment"] = r.experiment;
        o["label"] = r.label;
        o["model"] = r.model;
        o["q"] = r.quantiles;
        o["gmm_k"] = r.gmmComponents;
        o["density"] = r.density;
        o["members"] = r.members;
        o["rmse"] = r.rmse;
        o["render_ms"] = r.renderMs;
        o["memory_ratio"] = r.memoryRatio;
        o["image"] = r.image;
        o["rmse_members"] = r.rmseMembers;
        list.push_back(std::move(o));
    }
    return list.dump(1) + "\n";
}

std::vector<ResultRow> resultsFromJson(const std::string& text) {
    nlohmann::json list;
    try {
        list = nlohmann::json::parse(text);
    } catch (const nlohmann::json::exception& e) {
        UDVR_FAIL("results JSON: " << e.what());
    }
    if (!list.is_array()) UDVR_FAIL("results JSON: expected a list of rows");
    std::vector<ResultRow> rows;
    try {
        for (const auto& o : list) {
            ResultRow r;
            r.experiment = o.at("experiment").get<std::string>();
            r.label = o.at("label").get<std::string>();
            r.model = o.at("model").get<std::string>();
            r.quantiles = o.at("q").get<int>();
            r.gmmComponents = o.at("gmm_k").get<int>();
            r.density = o.at("density").get<std::string>();
            r.members = o.at("members").get<int>();
            // nlohmann writes NaN as null.
            auto num = [&](const char* key) {
                const auto& v = o.at(key);
                return v.is_null() ? std::numeric_limits<double>::quiet_NaN() : v.get<double>();
            };
            r.rmse = num("rmse");
            r.renderMs = num("render_ms");
            r.memoryRatio = num("memory_ratio");
            r.image = o.at("image").get<std::string>();
            if (o.contains("rmse_members")) r.rmseMembers = num("rmse_members");
            rows.push_back(std::move(r));
        }
    } catch (const nlohmann::json::exception& e) {
        UDVR_FAIL("results JSON: " << e.what());
    }
    return rows;
}

void writeResultsCsv(const std::filesystem::path& path, const std::vector<ResultRow>& rows) {
    writeFileAtomically(path, resultsToCsv(rows));
}
void writeResultsJson(const std::filesystem::path& path, const std::vector<ResultRow>& rows) {
    writeFileAtomically(path, resultsToJson(rows));
}
std::vector<ResultRow> readResultsCsv(const std::filesystem::path& path) {
    return resultsFromCsv(readText(path));
}
std::vector<ResultRow> readResultsJson(const std::filesystem::path& path) {
    return resultsFromJson(readText(path));
}

}  // namespace udvr
