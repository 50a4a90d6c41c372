// udvr info FILE… [--json] [--histogram out.png [--log] [--bins N] [--tf TF]] [--ensemble]
// What a field, ensemble, member list or model holds: grid, arrays and their types, value
// range and percentiles, model contents (SPEC §8).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "udvr/classify/tf_presets.h"
#include "udvr/cmd/commands.h"
#include "udvr/cmd/parse_util.h"
#include "udvr/eval/histogram_plot.h"
#include "udvr/io/ensemble_io.h"
#include "udvr/io/field_io.h"
#include "udvr/io/file_info.h"
#include "udvr/io/image.h"
#include "udvr/io/model_io.h"
#include "udvr/stats/value_summary.h"
#include "udvr/util/check.h"

namespace udvr::cmd {
namespace {

using json = nlohmann::ordered_json;  // keys in the order written

struct InfoOpts {
    std::vector<std::string> inputs;
    std::string histogram, var, memberDim;
    TfFlags tf;
    int bins = 256;
    bool json = false, logScale = false, ensemble = false, binsGiven = false;
    RawLayoutFlags raw;
};

json gridJson(const Grid3& g) {
    json j;
    j["dims"] = g.dims;
    j["spacing"] = g.spacing;
    j["origin"] = g.origin;
    j["bounds"] = g.bounds();
    j["points"] = g.pointCount();
    return j;
}

json summaryJson(const ValueSummary& s) {
    json j;
    j["count"] = s.count;
    j["min"] = s.min;
    j["max"] = s.max;
    j["mean"] = s.mean;
    j["stddev"] = s.stddev;
    json p = json::object();
    for (std::size_t i = 0; i < kSummaryPercentiles.size(); ++i) {
        char key[16];
        std::snprintf(key, sizeof key, "%g", kSummaryPercentiles[i]);
        p[key] = s.percentiles[i];
    }
    j["percentiles"] = p;
    return j;
}

json arraysJson(const std::vector<ArrayInfo>& arrays) {
    json list = json::array();
    for (const ArrayInfo& a : arrays) {
        json j;
        j["name"] = a.name;
        j["type"] = a.type;
        j["components"] = a.components;
        if (!a.dimNames.empty()) {
            j["dims"] = a.dimNames;
            j["sizes"] = a.dimSizes;
        }
        list.push_back(j);
    }
    return list;
}

bool isGlob(const std::string& s) { return s.find_first_of("*?[") != std::string::npos; }

// The values a histogram and a default TF describe: the field, all members, or the model's means.
struct Described {
    json info;
    std::vector<float> values;
    // The default TF's basis as render finds it (defaultTfBasisOf): on this grid, over
    // `basisValues` (an ensemble's member means; empty: `values`), or the recorded one.
    Grid3 grid;
    std::vector<float> basisValues;
    std::vector<double> recordedTf;
};

Described describeEnsemble(const std::vector<std::string>& inputs, const InfoOpts& o,
                           const std::string& label) {
    EnsembleReadOptions ro;
    ro.var = o.var;
    ro.memberDim = o.memberDim;
    ro.raw = toRawLayout(o.raw);
    Ensemble e = readEnsemble(inputs, ro);
    Described d;
    d.info["file"] = label;
    d.info["kind"] = "ensemble";
    d.info["grid"] = gridJson(e.grid);
    d.info["members"] = e.members;
    if (inputs.size() == 1 && lowerExtension(inputs[0]) == ".nc" && !e.name.empty())
        d.info["variable"] = e.name;
    // The arrays of the first member file (a glob's members are not listed here).
    if (!isGlob(inputs[0]) || std::filesystem::exists(inputs[0]))
        d.info["arrays"] = arraysJson(listArrays(inputs[0], ro.raw));
    // Per-voxel spread across the members (population standard deviation).
    const std::size_t n = e.grid.pointCount();
    double sum = 0.0, largest = 0.0;
    for (std::size_t p = 0; p < n; ++p) {
        double m = 0.0, ss = 0.0;
        for (int k = 0; k < e.members; ++k) m += e.member(k)[p];
        m /= e.members;
        for (int k = 0; k < e.members; ++k) ss += (e.member(k)[p] - m) * (e.member(k)[p] - m);
        const double sd = std::sqrt(ss / e.members);
        sum += sd;
        largest = std::max(largest, sd);
    }
    d.info["member_spread"] = {{"mean_stddev", sum / static_cast<double>(n)},
                               {"max_stddev", largest}};
    d.grid = e.grid;
    d.basisValues.resize(n);  // --model members renders over the member means
    for (std::size_t p = 0; p < n; ++p) {
        double m = 0.0;
        for (int k = 0; k < e.members; ++k) m += e.member(k)[p];
        d.basisValues[p] = static_cast<float>(m / e.members);
    }
    d.values = std::move(e.values);
    d.info["values"] = summaryJson(summarizeValues(d.values));
    return d;
}

Described describeFile(const std::string& path, const InfoOpts& o) {
    if (isGlob(path) && !std::filesystem::exists(path)) return describeEnsemble({path}, o, path);
    const RawLayout raw = toRawLayout(o.raw);
    const std::vector<ArrayInfo> arrays = listArrays(path, raw);
    const std::string ext = lowerExtension(path);
    bool model = false;
    if ((ext == ".vti" || ext == ".pvti") && o.var.empty())
        for (const ArrayInfo& a : arrays) model = model || a.name == "mean";
    // The chosen variable (or, without --var, any) with a member dimension: an ensemble.
    if (ext == ".nc" && netcdfHoldsEnsemble(arrays, o.var))
        return describeEnsemble({path}, o, path);
    Described d;
    d.info["file"] = path;
    d.info["arrays"] = arraysJson(arrays);
    if (model) {
        ModelVolume m = readModelVti(path);
        d.info["kind"] = "model";
        d.info["grid"] = gridJson(m.grid);
        json mj;
        mj["samples_per_voxel"] = m.samplesPerVoxel;
        mj["downsample"] = m.downsample;
        mj["quantiles"] = m.hasQuantiles() ? m.quantileCount : 0;
        if (m.hasQuantiles() && !m.quantileLevels.empty()) mj["quantile_levels"] = m.quantileLevels;
        mj["iqr"] = !m.iqr.empty();
        mj["gmm_components"] = m.hasGmm() ? m.gmmComponents : 0;
        mj["density"] = m.density;
        if (m.density == "kde") {
            mj["bandwidth_rule"] = m.bandwidthRule;
            mj["bandwidth_median"] = m.bandwidth;
            mj["tail_eps"] = m.tailEps;
        } else if (m.density == "dequantized") {
            mj["value_step"] = m.bandwidth;
        }
        mj["full_resolution_bounds"] = m.bounds;
        mj["full_resolution_min_spacing"] = m.fullResMinSpacing;
        mj["source"] = m.source;
        if (!m.stddev.empty()) mj["stddev"] = summaryJson(summarizeValues(m.stddev));
        d.info["model"] = mj;
        d.grid = m.grid;
        d.recordedTf = std::move(m.defaultTf);
        d.values = std::move(m.mean);
    } else {
        FieldReadOptions fo;
        fo.var = o.var;
        fo.raw = raw;
        ScalarField f = readField(path, fo);
        d.info["kind"] = "field";
        d.info["grid"] = gridJson(f.grid);
        d.grid = f.grid;
        if (!f.name.empty()) d.info["variable"] = f.name;
        for (const ArrayInfo& a : arrays)
            if (arrays.size() == 1 || a.name == f.name) d.info["type"] = a.type;
        d.values = std::move(f.values);
    }
    d.info["values"] = summaryJson(summarizeValues(d.values));
    return d;
}

std::string joined(const json& list) {
    std::string s;
    for (const auto& v : list) s += (s.empty() ? "" : "x") + v.dump();
    return s;
}

void printText(const json& j) {
    std::printf("%s: %s", j["file"].get<std::string>().c_str(),
                j["kind"].get<std::string>().c_str());
    if (j.contains("members")) std::printf(" of %d members", j["members"].get<int>());
    if (j.contains("variable"))
        std::printf(" (variable '%s')", j["variable"].get<std::string>().c_str());
    std::printf("\n");
    const json& g = j["grid"];
    const auto b = g["bounds"].get<std::array<double, 6>>();
    std::printf("  grid      %s points (%s), spacing %g %g %g, origin %g %g %g\n",
                joined(g["dims"]).c_str(), g["points"].dump().c_str(),
                g["spacing"][0].get<double>(), g["spacing"][1].get<double>(),
                g["spacing"][2].get<double>(), g["origin"][0].get<double>(),
                g["origin"][1].get<double>(), g["origin"][2].get<double>());
    std::printf("  bounds    [%g, %g] x [%g, %g] x [%g, %g]\n", b[0], b[1], b[2], b[3], b[4], b[5]);
    if (j.contains("type")) std::printf("  type      %s\n", j["type"].get<std::string>().c_str());
    if (j.contains("arrays") && !j["arrays"].empty()) {
        std::printf("  arrays   ");
        for (const auto& a : j["arrays"]) {
            std::printf(" %s (%s", a["name"].get<std::string>().c_str(),
                        a["type"].get<std::string>().c_str());
            if (a["components"].get<int>() > 1) std::printf(" x%d", a["components"].get<int>());
            if (a.contains("dims")) {
                std::string dims;
                for (std::size_t k = 0; k < a["dims"].size(); ++k)
                    dims += (k ? "," : "") + a["dims"][k].get<std::string>() + "=" +
                            a["sizes"][k].dump();
                std::printf(", %s", dims.c_str());
            }
            std::printf(")");
        }
        std::printf("\n");
    }
    const json& v = j["values"];
    std::printf("  %s min %.6g  max %.6g  mean %.6g  stddev %.6g\n",
                j.contains("model") ? "means    " : "values   ", v["min"].get<double>(),
                v["max"].get<double>(), v["mean"].get<double>(), v["stddev"].get<double>());
    std::printf("  percentiles");
    for (const auto& [p, x] : v["percentiles"].items())  // ascending, as written
        std::printf("  %s%%: %.6g", p.c_str(), x.get<double>());
    std::printf("\n");
    if (j.contains("member_spread"))
        std::printf("  spread    per-voxel stddev across members: mean %.6g, max %.6g\n",
                    j["member_spread"]["mean_stddev"].get<double>(),
                    j["member_spread"]["max_stddev"].get<double>());
    if (j.contains("model")) {
        const json& m = j["model"];
        std::printf("  model     %s from %d samples per voxel",
                    m["density"].get<std::string>().c_str(), m["samples_per_voxel"].get<int>());
        if (m["downsample"].get<int>() > 0)
            std::printf(" (%d^3 bricks of one field)", m["downsample"].get<int>());
        std::printf("; q = %d quantiles, GMM K = %d%s\n", m["quantiles"].get<int>(),
                    m["gmm_components"].get<int>(), m["iqr"].get<bool>() ? ", IQR" : "");
        if (m.contains("quantile_levels")) {
            std::printf("  levels   ");
            for (const json& t : m["quantile_levels"]) std::printf(" %.6g", t.get<double>());
            std::printf(" (uneven)\n");
        }
        if (m.contains("bandwidth_rule"))
            std::printf("  kde       bandwidth %s (median h %.6g), tail eps %.3g\n",
                        m["bandwidth_rule"].get<std::string>().c_str(),
                        m["bandwidth_median"].get<double>(), m["tail_eps"].get<double>());
        if (m.contains("value_step"))
            std::printf("  dequant   each sample spread over its quantisation step %.6g\n",
                        m["value_step"].get<double>());
        const auto fb = m["full_resolution_bounds"].get<std::array<double, 6>>();
        std::printf("  full res  bounds [%g, %g] x [%g, %g] x [%g, %g], smallest spacing %g\n",
                    fb[0], fb[1], fb[2], fb[3], fb[4], fb[5],
                    m["full_resolution_min_spacing"].get<double>());
        if (m.contains("stddev"))
            std::printf("  stddev    per voxel: mean %.6g, max %.6g\n",
                        m["stddev"]["mean"].get<double>(), m["stddev"]["max"].get<double>());
        if (!m["source"].get<std::string>().empty())
            std::printf("  source    %s\n", m["source"].get<std::string>().c_str());
    }
}

void run(const InfoOpts& o) {
    if (!o.histogram.empty()) {
        if (lowerExtension(o.histogram) != ".png")
            UDVR_FAIL("--histogram must name a .png file, got '" << o.histogram << "'");
        requireOutputDirectory(o.histogram, "--histogram");
        std::vector<std::string> inputs = o.inputs;
        inputs.push_back(o.tf.tf);
        requireOutputsNotInputs({{"--histogram", o.histogram}}, inputs);
        if (o.inputs.size() != 1 && !o.ensemble)
            UDVR_FAIL("--histogram draws one input; got " << o.inputs.size()
                                                          << " (add --ensemble for a member list)");
    } else if (o.logScale || o.binsGiven || !o.tf.tf.empty() || !o.tf.range.empty() ||
               !o.tf.save.empty()) {
        UDVR_FAIL(
            "--log, --bins, --tf, --tf-range and --save-tf go with the histogram: add "
            "--histogram h.png");
    }
    if (o.bins < 1 || o.bins > 65536) UDVR_FAIL("--bins must be in [1, 65536], got " << o.bins);
    checkTfFlags(o.tf);
    std::vector<Described> all;
    if (o.ensemble) {
        std::string label;
        for (const std::string& in : o.inputs) label += (label.empty() ? "" : " ") + in;
        all.push_back(describeEnsemble(o.inputs, o, label));
    } else {
        for (const std::string& in : o.inputs) all.push_back(describeFile(in, o));
    }
    if (!o.histogram.empty()) {
        const Described& d = all.front();
        const json& v = d.info["values"];
        double lo = v["min"].get<double>(), hi = v["max"].get<double>();
        if (!(hi > lo)) lo -= 0.5, hi += 0.5;
        const Histogram h = histogramOf(d.values, lo, hi, o.bins);
        HistogramPlotOptions po;
        po.logScale = o.logScale;
        po.title = d.info["file"].get<std::string>() + " (" + d.info["kind"].get<std::string>() +
                   (d.info["kind"] == "model" ? " means)" : " values)");
        // The TF render uses for this input with the same flags (without --tf: the default).
        const TfChoice tf = chooseTransferFunction(
            o.tf,
            [&] {
                ModelVolume m;
                m.grid = d.grid;
                m.mean = d.basisValues.empty() ? d.values : d.basisValues;
                m.defaultTf = d.recordedTf;
                return defaultTfBasisOf(m);
            },
            "info");
        writePng(o.histogram, renderHistogramPlot(h, &tf.tf, po));
        finishTransferFunction(o.tf, tf);
        std::uint64_t fullest = 0;
        int filled = 0;
        for (auto c : h.counts) fullest = std::max(fullest, c), filled += c > 0;
        if (!o.logScale && filled > 1 &&
            static_cast<double>(fullest) > 0.5 * static_cast<double>(d.values.size()))
            std::fprintf(
                stderr, "info: one bin holds %.0f%% of the values: --log shows the rest\n",
                100.0 * static_cast<double>(fullest) / static_cast<double>(d.values.size()));
        std::fprintf(stderr, "info: histogram of %zu values in %d bins over [%g, %g] -> %s\n",
                     d.values.size(), o.bins, lo, hi, o.histogram.c_str());
    }
    if (o.json) {
        if (all.size() == 1) {
            std::cout << all.front().info.dump(2) << "\n";
        } else {
            json list = json::array();
            for (const Described& d : all) list.push_back(d.info);
            std::cout << list.dump(2) << "\n";
        }
        return;
    }
    for (const Described& d : all) printText(d.info);
}

}  // namespace

void addInfoCommand(CLI::App& app) {
    auto* sub = app.add_subcommand("info",
                                   "what a field, ensemble, member list or model holds: grid, "
                                   "arrays, types, value range and percentiles, model contents");
    auto o = std::make_shared<InfoOpts>();
    sub->add_option("inputs", o->inputs,
                    "fields (.vti .nc .nrrd .nhdr .raw), ensembles (.nc), quoted member globs "
                    "('m_*.nhdr') or models (.vti)")
        ->required();
    sub->add_flag("--json", o->json, "print JSON (one object, or a list for several inputs)");
    sub->add_option("--histogram", o->histogram,
                    "write a PNG of the value histogram (a model's means) of the one input, under "
                    "the TF render uses for it (the default, or --tf/--tf-range)");
    sub->add_flag("--log", o->logScale, "histogram: bar height log10(1 + count)");
    auto* bins = sub->add_option("--bins", o->bins, "histogram bins (default 256)");
    addTfOptions(sub, o->tf);
    sub->add_flag("--ensemble", o->ensemble, "read all inputs as the members of one ensemble");
    sub->add_option("--var", o->var, "variable/array to read");
    sub->add_option("--member-dim", o->memberDim, "NetCDF member dimension name");
    addRawLayoutOptions(sub, o->raw);
    sub->callback([o, bins] {
        o->inputs = withOneMatchResolved(o->inputs);  // a quoted glob of one file is that file
        o->binsGiven = bins->count() > 0;
        run(*o);
    });
}

}  // namespace udvr::cmd
