#include "udvr/eval/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <sstream>

namespace udvr {
namespace {

std::string fmt(const char* format, double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, format, v);
    return buf;
}
std::string rmseText(double v) { return fmt("%.4f", v); }

/// The row of `model` (with q when q ≥ 0, density when non-empty, members when ≥ 0).
const ResultRow* findRow(const std::vector<ResultRow>& rows, const std::string& model, int q = -1,
                         const std::string& density = "", int members = -1) {
    for (const ResultRow& r : rows)
        if (r.model == model && (q < 0 || r.quantiles == q) &&
            (density.empty() || r.density == density) && (members < 0 || r.members == members))
            return &r;
    return nullptr;
}

std::string verdictOf(bool holds) { return holds ? "holds" : "does not hold"; }

ClaimCheck notMeasured(std::string claim, std::string why) {
    return {std::move(claim), "not measured", std::move(why)};
}

/// Fig. 4: nonparametric q = 8 beats mean, uniform and gaussian.
ClaimCheck beatsParametric(const std::vector<ResultRow>& rows, const std::string& figure) {
    std::string claim =
        "Nonparametric models with q = 8 (quantile-range, quantile-mean) have a "
        "lower RMSE than the mean, uniform and gaussian models (" +
        figure + ")";
    const ResultRow* qr = findRow(rows, "quantile-range", 8);
    const ResultRow* qm = findRow(rows, "quantile-mean", 8);
    std::vector<const ResultRow*> refs = {findRow(rows, "mean"), findRow(rows, "uniform"),
                                          findRow(rows, "gaussian")};
    if (!qr || !qm || std::count(refs.begin(), refs.end(), nullptr) > 0)
        return notMeasured(claim, "the run lacks one of the models");
    double best = refs[0]->rmse;
    std::string bestName = refs[0]->model;
    for (const ResultRow* r : refs)
        if (r->rmse < best) best = r->rmse, bestName = r->model;
    const bool qrWins = qr->rmse < best, qmWins = qm->rmse < best;
    std::string verdict = qrWins && qmWins   ? "holds"
                          : qrWins || qmWins ? "partly holds"
                                             : "does not hold";
    std::string detail = "quantile-range q=8 " + rmseText(qr->rmse) + ", quantile-mean q=8 " +
                         rmseText(qm->rmse) + " vs the best of mean/uniform/gaussian (" + bestName +
                         ") " + rmseText(best) + "; mean " + rmseText(refs[0]->rmse) +
                         ", uniform " + rmseText(refs[1]->rmse) + ", gaussian " +
                         rmseText(refs[2]->rmse);
    return {claim, verdict, detail};
}

/// The model with the lowest RMSE among everything but the references (ground truth, members).
const ResultRow* lowestRmse(const std::vector<ResultRow>& rows) {
    const ResultRow* best = nullptr;
    for (const ResultRow& r : rows)
        if (r.model != "ground-truth" && r.model != "members" && std::isfinite(r.rmse) &&
            (!best || r.rmse < best->rmse))
            best = &r;
    return best;
}

ClaimCheck lowestIs(const std::vector<ResultRow>& rows, const std::string& model, int q,
                    const std::string& claim) {
    const ResultRow* target = findRow(rows, model, q);
    const ResultRow* best = lowestRmse(rows);
    if (!target || !best) return notMeasured(claim, "the run lacks the model");
    const bool holds = target->rmse <= best->rmse;
    std::string detail = target->label + " " + rmseText(target->rmse);
    if (!holds) detail += "; lowest: " + best->label + " " + rmseText(best->rmse);
    return {claim, verdictOf(holds), detail};
}

std::vector<ClaimCheck> ensembleClaims(const std::vector<ResultRow>& rows, bool tangle) {
    std::vector<ClaimCheck> out;
    out.push_back(beatsParametric(rows, tangle ? "Fig. 4" : "teaser a"));
    if (!tangle) return out;
    {
        const std::string claim =
            "Increasing the quantiles from q = 2 to q = 4 lowers the RMSE (Fig. 4 q–r); q = 8 "
            "is lower than q = 2 with 50 members";
        std::string detail;
        bool all = true, any = false;
        bool measured = false;
        for (const char* model : {"quantile-range", "quantile-mean"}) {
            const ResultRow* r2 = findRow(rows, model, 2);
            const ResultRow* r4 = findRow(rows, model, 4);
            const ResultRow* r8 = findRow(rows, model, 8);
            if (!r2 || !r4 || !r8) continue;
            measured = true;
            const bool ok = r4->rmse < r2->rmse && r8->rmse < r2->rmse;
            all = all && ok;
            any = any || ok;
            if (!detail.empty()) detail += "; ";
            detail += std::string(model) + ": q=2 " + rmseText(r2->rmse) + ", q=4 " +
                      rmseText(r4->rmse) + ", q=8 " + rmseText(r8->rmse);
        }
        if (!measured)
            out.push_back(notMeasured(claim, "the run lacks q = 2, 4, 8"));
        else
            out.push_back({claim, all ? "holds" : any ? "partly holds" : "does not hold", detail});
    }
    out.push_back(lowestIs(rows, "iqr", -1, "IQR gives the lowest RMSE of all models (Fig. 4v)"));
    {
        const std::string claim =
            "Quantile-mean (q = 8) renders at frame rates comparable to the parametric models "
            "(Fig. 5b); judged here as at most 2× the slower of uniform and gaussian";
        const ResultRow* qm = findRow(rows, "quantile-mean", 8);
        const ResultRow* u = findRow(rows, "uniform");
        const ResultRow* g = findRow(rows, "gaussian");
        if (!qm || !u || !g) {
            out.push_back(notMeasured(claim, "the run lacks the models"));
        } else {
            const double ref = std::max(u->renderMs, g->renderMs);
            const double ratio = ref > 0 ? qm->renderMs / ref : INFINITY;
            std::string detail = "quantile-mean " + fmt("%.1f", qm->renderMs) + " ms, uniform " +
                                 fmt("%.1f", u->renderMs) + " ms, gaussian " +
                                 fmt("%.1f", g->renderMs) + " ms (ratio " + fmt("%.2f", ratio) +
                                 ")";
            if (const ResultRow* m = findRow(rows, "mean"))
                detail += "; mean " + fmt("%.1f", m->renderMs) + " ms";
            if (const ResultRow* go = findRow(rows, "gmm-ordered"))
                detail += ", gmm-ordered " + fmt("%.1f", go->renderMs) + " ms";
            if (const ResultRow* qr = findRow(rows, "quantile-range", 8))
                detail += ", quantile-range " + fmt("%.1f", qr->renderMs) + " ms";
            out.push_back({claim, verdictOf(ratio <= 2.0), detail});
        }
    }
    {
        const std::string claim =
            "The mean field has a higher RMSE than the uniform model (Fig. 4: 0.0245 vs 0.0200)";
        const ResultRow* m = findRow(rows, "mean");
        const ResultRow* u = findRow(rows, "uniform");
        if (!m || !u)
            out.push_back(notMeasured(claim, "the run lacks the models"));
        else
            out.push_back({claim, verdictOf(m->rmse > u->rmse),
                           "mean " + rmseText(m->rmse) + ", uniform " + rmseText(u->rmse)});
    }
    return out;
}

std::vector<ClaimCheck> sweepClaims(const std::vector<ResultRow>& rows) {
    std::vector<ClaimCheck> out;
    std::set<int> memberSet;
    std::set<std::string> densities;
    for (const ResultRow& r : rows)
        if (r.quantiles > 0) memberSet.insert(r.members), densities.insert(r.density);
    if (memberSet.empty()) {
        out.push_back(notMeasured("Fig. 5a", "no quantile rows"));
        return out;
    }
    const int most = *memberSet.rbegin(), fewest = *memberSet.begin();
    auto compare = [&](int members, bool expectMoreHelps, const std::string& claim) {
        std::string detail;
        int agree = 0, total = 0;
        for (const std::string& d : densities)
            for (const char* model : {"quantile-range", "quantile-mean"}) {
                const ResultRow* r2 = findRow(rows, model, 2, d, members);
                const ResultRow* r4 = findRow(rows, model, 4, d, members);
                const ResultRow* r8 = findRow(rows, model, 8, d, members);
                if (!r2 || !r4 || !r8) continue;
                const double better = std::min(r4->rmse, r8->rmse);
                const bool helps = better < r2->rmse;
                ++total;
                if (helps == expectMoreHelps) ++agree;
                if (!detail.empty()) detail += "; ";
                detail += std::string(model) + "/" + d + ": q=2 " + rmseText(r2->rmse) + ", q=4 " +
                          rmseText(r4->rmse) + ", q=8 " + rmseText(r8->rmse);
            }
        if (total == 0) return notMeasured(claim, "the run lacks q = 2, 4, 8");
        const std::string verdict = agree == total ? "holds"
                                    : agree > 0    ? "partly holds"
                                                   : "does not hold";
        return ClaimCheck{claim, verdict,
                          std::to_string(agree) + " of " + std::to_string(total) +
                              " model/density pairs agree; " + detail};
    };
    out.push_back(compare(most, true,
                          "With enough members (" + std::to_string(most) +
                              "), q = 4 or 8 gives a lower RMSE than q = 2 (Fig. 5a)"));
    if (fewest != most)
        out.push_back(compare(fewest, false,
                              "With few members (" + std::to_string(fewest) +
                                  "), q = 4/8 gives a higher RMSE than q = 2 (Fig. 5a)"));
    // Which density estimate serves which ensemble size (SPEC §2 leaves it to the experiments).
    if (densities.count("empirical") && densities.count("kde")) {
        std::string detail;
        for (int m : memberSet) {
            int kdeWins = 0, total = 0;
            for (int q : {2, 4, 8})
                for (const char* model : {"quantile-range", "quantile-mean"}) {
                    const ResultRow* e = findRow(rows, model, q, "empirical", m);
                    const ResultRow* k = findRow(rows, model, q, "kde", m);
                    if (!e || !k) continue;
                    ++total;
                    if (k->rmse < e->rmse) ++kdeWins;
                }
            if (!detail.empty()) detail += "; ";
            detail += std::to_string(m) + " members: kde lower in " + std::to_string(kdeWins) +
                      " of " + std::to_string(total);
        }
        out.push_back(
            {"Which density estimate to use (SPEC §2): KDE vs empirical quantiles by "
             "ensemble size",
             "measured", detail});
    }
    return out;
}

std::string escapeCell(const std::string& s) {
    std::string out;
    for (char c : s) {
        if (c == '|') out += '\\';
        out += c;
    }
    return out;
}

}  // namespace

std::vector<ClaimCheck> checkClaims(const std::string& name, const std::vector<ResultRow>& rows) {
    if (name == "tangle") return ensembleClaims(rows, true);
    if (name == "teardrop") return ensembleClaims(rows, false);
    if (name == "tangle-sweep") return sweepClaims(rows);
    if (name == "spheres")
        return {beatsParametric(rows, "Fig. 8"),
                lowestIs(rows, "quantile-mean", 8,
                         "Quantile-mean has the lowest RMSE of the models (Fig. 8)")};
    if (name == "chest")
        return {beatsParametric(rows, "teaser b"),
                lowestIs(rows, "quantile-mean", 8,
                         "Quantile-mean has the lowest RMSE of the models (Fig. 9, OBELIX; here "
                         "the chest CT)")};
    if (name == "quartiles") {
        const ResultRow* lo = findRow(rows, "quartile-lower");
        const ResultRow* mid = findRow(rows, "quartile-middle");
        const ResultRow* up = findRow(rows, "quartile-upper");
        const std::string claim =
            "The quartile view shows where the data are uncertain: the lower and upper quartile "
            "images differ from the middle one (Fig. 6)";
        if (!lo || !mid || !up) return {notMeasured(claim, "the run lacks the quartile images")};
        return {{claim, "see the figure",
                 "RMSE vs ground truth: lower " + rmseText(lo->rmse) + ", middle " +
                     rmseText(mid->rmse) + ", upper " + rmseText(up->rmse)}};
    }
    return {};
}

std::string resultsMarkdownTable(const std::vector<ResultRow>& rows) {
    // The column against the members image only where an ensemble experiment rendered one.
    const bool members = std::any_of(
        rows.begin(), rows.end(), [](const ResultRow& r) { return std::isfinite(r.rmseMembers); });
    std::ostringstream os;
    os << "| image | model | q | density | members | RMSE |"
       << (members ? " RMSE vs members |" : "") << " render ms | memory × mean |\n"
       << "|---|---|---:|---|---:|---:|" << (members ? "---:|" : "") << "---:|---:|\n";
    for (const ResultRow& r : rows) {
        os << "| " << escapeCell(r.label) << " | " << escapeCell(r.model) << " | "
           << (r.quantiles > 0 ? std::to_string(r.quantiles) : "") << " | " << r.density << " | "
           << r.members << " | " << fmt("%.5f", r.rmse) << " | ";
        if (members)
            os << (std::isfinite(r.rmseMembers) ? fmt("%.5f", r.rmseMembers) : "") << " | ";
        os << fmt("%.1f", r.renderMs) << " | " << fmt("%g", r.memoryRatio) << " |\n";
    }
    return os.str();
}

std::string experimentReport(const ExperimentResult& result, const std::string& title,
                             const std::vector<std::string>& setup,
                             const std::vector<std::string>& figures,
                             const std::vector<ReportSection>& sections) {
    std::ostringstream os;
    os << "# " << title << "\n\n";
    os << "`udvr experiment " << result.name << "`; wall time " << fmt("%.1f", result.seconds)
       << " s.\n\n";
    if (!setup.empty()) {
        os << "## Setup\n\n";
        for (const std::string& s : setup) os << "- " << s << "\n";
        os << "\n";
    }
    for (const std::string& f : figures) os << "![" << f << "](" << f << ")\n\n";
    os << "## Results\n\n"
       << "RMSE per SPEC §6 (per-pixel |mean RGB − ground-truth mean RGB|, values in [0,1]); "
          "memory is stored values per voxel relative to the mean field.";
    if (std::any_of(result.rows.begin(), result.rows.end(),
                    [](const ResultRow& r) { return r.model == "members"; }))
        os << " RMSE vs members: the same against the ensemble's own expected image (`members`: "
              "the TF averaged over the members at each sample, no model), for the images "
              "rendered after it.";
    os << "\n\n" << resultsMarkdownTable(result.rows) << "\n";
    for (const ReportSection& sec : sections)
        os << "## " << sec.title << "\n\n" << sec.markdown << "\n";
    if (!result.claims.empty()) {
        os << "## The paper's claims in this run\n\n";
        for (const ClaimCheck& c : result.claims)
            os << "- **" << c.verdict << "** — " << c.claim << ". " << c.detail << ".\n";
        os << "\n";
    }
    os << "## Files\n\n";
    for (const auto& f : result.files) os << "- `" << f.generic_string() << "`\n";
    return os.str();
}

std::string summaryReport(const std::vector<ExperimentResult>& results,
                          const std::vector<std::string>& skipped) {
    std::ostringstream os;
    os << "# udvr experiments\n\n";
    for (const ExperimentResult& r : results) {
        os << "## [" << r.name << "](" << r.name << "/report.md)\n\n"
           << "Wall time " << fmt("%.1f", r.seconds) << " s. ![figure](" << r.name
           << "/figure.png)\n\n";
        for (const ClaimCheck& c : r.claims)
            os << "- **" << c.verdict << "** — " << c.claim << ". " << c.detail << ".\n";
        os << "\n";
    }
    for (const std::string& s : skipped) os << "- skipped: " << s << "\n";
    return os.str();
}

}  // namespace udvr
