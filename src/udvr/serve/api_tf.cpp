// `udvr serve`'s TF endpoints: the 1D TF and presets, the 2D TF (widgets, its row), and the
// histograms the editors draw (/api/histogram, /api/histogram2d).
#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <type_traits>
#include <variant>

#include "udvr/classify/model_families.h"
#include "udvr/classify/probe.h"
#include "udvr/classify/tf_presets.h"
#include "udvr/classify/transfer_function_2d_widgets.h"
#include "udvr/eval/image_metrics.h"
#include "udvr/eval/tf2_plot.h"
#include "udvr/io/transfer_function_2d_io.h"
#include "udvr/io/transfer_function_io.h"
#include "udvr/reconstruct/gradient_field.h"
#include "udvr/render/framing.h"
#include "udvr/render/render_options.h"
#include "udvr/serve/api.h"
#include "udvr/serve/api_query.h"
#include "udvr/stats/value_summary.h"
#include "udvr/util/build_info.h"
#include "udvr/util/check.h"
#include "udvr/util/json_text.h"
#include "udvr/util/text_parse.h"

namespace udvr::serve {

using nlohmann::json;

std::string completeWidgetJson(const std::string& text, const std::string& what,
                               const TransferFunction2D& tf) {
    json doc = parseJsonText(text, what);
    doc["domain"] = {tf.x0, tf.x1, tf.y0, tf.y1};
    doc["resolution"] = {tf.width, tf.height};
    return doc.dump(1, ' ', false, json::error_handler_t::replace) + "\n";
}

ApiResponse Api::getHistogram(const ApiRequest& request) {
    const Query q(request.params, {{"bins", "source", "lo", "hi"}});
    const int bins = static_cast<int>(q.whole("bins", 1, kMaxHistogramBins).value_or(256));
    const std::string source = q.text("source", "model");
    if (source != "model" && source != "truth" && source != "second")
        UDVR_FAIL("source must be model, truth or second, got '" << Query::clip(source) << "'");
    const ModelVolume* volume = &data_.model;
    if (source == "truth") volume = data_.truth ? &*data_.truth : nullptr;
    if (source == "second") volume = data_.second ? &*data_.second : nullptr;
    if (!volume)
        UDVR_FAIL("no " << source << " field: udvr serve was started without --" << source);
    const std::vector<float>& values = volume->mean;
    if (values.empty()) UDVR_FAIL("the " << source << " has no values");
    const auto loGiven = q.number("lo", -1e300, 1e300), hiGiven = q.number("hi", -1e300, 1e300);
    Histogram h;
    std::optional<ValueSummary> summary;
    std::array<double, 2> robust{};
    inGate(request, [&] {
        const auto [mn, mx] = std::minmax_element(values.begin(), values.end());
        double lo = loGiven.value_or(*mn), hi = hiGiven.value_or(*mx);
        if (!(hi > lo)) {
            if (loGiven || hiGiven) UDVR_FAIL("hi must be above lo");
            lo -= 0.5, hi += 0.5;
        }
        h = histogramOf(values, lo, hi, bins);
        summary = summarizeValues(values);
        robust = robustRange(*summary);
    });
    return jsonResponse(json{
        {"source", source},
        {"values", volume->quantileCount > 0 || volume->gmmComponents > 0 || !volume->stddev.empty()
                       ? "means"
                       : "values"},
        {"lo", h.lo},
        {"hi", h.hi},
        {"counts", h.counts},
        {"below", h.below},
        {"above", h.above},
        {"robust_range", robust},
        {"median", summary->percentile(50)}});
}

ApiResponse Api::getTf() {
    const auto [tf, version] = currentTf();
    ApiResponse out;
    out.body = transferFunctionToJson(*tf, "udvr serve");
    out.headers.emplace_back("X-Udvr-Tf-Version", std::to_string(version));
    return out;
}

ApiResponse Api::postTf(const ApiRequest& request) {
    if (request.body.size() > data_.maxBodyBytes)
        UDVR_FAIL("the TF JSON is over " << data_.maxBodyBytes << " bytes");
    auto tf = std::make_shared<TransferFunction1D>(
        parseTransferFunction(request.body, "the posted transfer function"));
    tf->validate();
    std::lock_guard lock(tfMutex_);
    tf_ = std::move(tf);
    const std::uint64_t version = ++tfVersion_;
    return jsonResponse(json{{"tf_version", version}});
}

ApiResponse Api::getPreset(const ApiRequest& request) {
    const Query q(request.params, {{"name", "range"}});
    const std::string name = q.text("name", transferFunctionPresetNames().front());
    if (!isTransferFunctionPreset(name))
        UDVR_FAIL("unknown preset '" << Query::clip(name) << "' (expected one of: "
                                     << transferFunctionPresetList() << ")");
    std::optional<std::array<double, 2>> range;
    if (q.has("range")) {
        const auto v = parseDoubleList(q.text("range"), "range");
        if (v.size() != 2 || !(v[1] > v[0])) UDVR_FAIL("range must be lo,hi with lo < hi");
        range = std::array<double, 2>{v[0], v[1]};
    }
    ApiResponse out;
    inGate(request, [&] {  // percentiles of every voxel
        out.body = transferFunctionToJson(
            transferFunctionPresetOver(name, defaultTfBasisOf(data_.model), range).tf, name);
    });
    return out;
}

ApiResponse Api::getHistogram2D(const ApiRequest& request) {
    const Query q(request.params, {{"bins", "domain"}});
    std::array<int, 2> bins{128, 128};
    if (q.has("bins")) {
        const std::string text = q.text("bins");
        bins = parseSize(text, "bins", kMaxHistogram2DBins);  // N or NXxNY
        if (bins[0] > kMaxHistogram2DBins || bins[1] > kMaxHistogram2DBins)
            UDVR_FAIL("bins must be N or NXxNY with 1 <= N <= " << kMaxHistogram2DBins << ", got '"
                                                                << Query::clip(text) << "'");
    }
    std::optional<std::array<double, 4>> domainGiven;
    if (q.has("domain")) {
        const auto v = parseDoubleList(q.text("domain"), "domain");
        if (v.size() != 4 || !(v[1] > v[0]) || !(v[3] > v[2]))
            UDVR_FAIL("domain must be x0,x1,y0,y1 with x0 < x1 and y0 < y1");
        domainGiven = {v[0], v[1], v[2], v[3]};
    }
    const Tf2State tf2 = currentTf2();
    JointHistogram h;
    inGate(request, [&] {
        // x: the model's means; y: their gradient magnitudes (as `udvr tf2 --volume`), or the
        // second field's means with --second.
        const std::vector<float>& x = data_.model.mean;
        const std::vector<float>* y = nullptr;
        if (data_.second) {
            y = &data_.second->mean;
        } else {
            std::lock_guard lock(gradientMutex_);
            if (gradientMagnitudes_.empty())
                gradientMagnitudes_ = gridGradientMagnitudes(data_.model.grid, x.data());
            y = &gradientMagnitudes_;
        }
        if (x.empty() || x.size() != y->size()) UDVR_FAIL("the model has no values");
        std::array<double, 4> domain{};
        if (domainGiven) {
            domain = *domainGiven;
        } else if (tf2.tf) {
            domain = {tf2.tf->x0, tf2.tf->x1, tf2.tf->y0, tf2.tf->y1};
        } else {  // the data's ranges
            const auto [x0, x1] = std::minmax_element(x.begin(), x.end());
            const auto [y0, y1] = std::minmax_element(y->begin(), y->end());
            domain = {*x0, *x1 > *x0 ? *x1 : *x0 + 1.0, *y0, *y1 > *y0 ? *y1 : *y0 + 1.0};
        }
        h = jointHistogram(x, *y, bins[0], bins[1], domain);
    });
    std::vector<std::uint64_t> counts(h.counts.size());
    for (std::size_t k = 0; k < counts.size(); ++k)
        counts[k] = static_cast<std::uint64_t>(h.counts[k]);
    return jsonResponse(json{{"x", data_.second ? "field 1 (mean)" : "value (mean)"},
                             {"y", data_.second ? "field 2 (mean)" : "gradient magnitude"},
                             {"bins", {h.binsX, h.binsY}},
                             {"domain", h.domain},
                             {"counts", counts},
                             {"total", h.total},
                             {"outside", h.outside},
                             {"range", {h.xMin, h.xMax, h.yMin, h.yMax}}});
}

ApiResponse Api::getTf2() {
    const Tf2State tf2 = currentTf2();
    if (!tf2.tf) UDVR_FAIL("no 2D transfer function: start udvr serve with --tf2 WIDGETS.json");
    if (!tf2.widgets)
        UDVR_FAIL("the 2D transfer function " << data_.tf2File
                                              << " is a raster: it renders but is not editable "
                                                 "(start with a widget .json to edit)");
    ApiResponse out;
    out.body = *tf2.widgets;
    out.headers.emplace_back("X-Udvr-Tf-Version", std::to_string(tf2.version));
    return out;
}

ApiResponse Api::postTf2(const ApiRequest& request) {
    if (!currentTf2().tf)
        UDVR_FAIL("no 2D transfer function to replace: start udvr serve with --tf2 WIDGETS.json");
    if (request.body.size() > data_.maxBodyBytes)
        UDVR_FAIL("the 2D TF JSON is over " << data_.maxBodyBytes << " bytes");
    const std::string what = "the posted 2D transfer function";
    // Check the sizes before rasterising: W·H points × widgets is the work.
    const Tf2WidgetFile file = parseTf2Widgets(request.body, what);
    if (file.widgets.size() > kMaxPostedTf2Widgets)
        UDVR_FAIL(what << ": " << file.widgets.size() << " widgets, at most "
                       << kMaxPostedTf2Widgets);
    if (file.resolution && ((*file.resolution)[0] > kMaxPostedTf2Resolution ||
                            (*file.resolution)[1] > kMaxPostedTf2Resolution))
        UDVR_FAIL(what << ": resolution " << (*file.resolution)[0] << "x" << (*file.resolution)[1]
                       << " is over " << kMaxPostedTf2Resolution << " points per axis");
    // The rasterisation's work: every raster point evaluates every widget (a band each segment).
    const auto [width, height] =
        file.resolution.value_or(std::array<int, 2>{kDefaultTf2Resolution, kDefaultTf2Resolution});
    const double work = tf2WidgetWork(file.widgets, width, height);
    const double terms = work / (static_cast<double>(width) * height);
    if (work > kMaxPostedTf2Work)
        UDVR_FAIL(what << ": " << width << "x" << height << " points x " << terms
                       << " widget terms (a band counts its segments) is over the limit of "
                       << kMaxPostedTf2Work << "; use fewer band points or a coarser resolution");
    // As `udvr render --tf2 FILE` reads the same text, in a turn of the gate (it is heavy work).
    std::shared_ptr<TransferFunction2D> tf;
    Tf2ReadOptions ro;
    ro.force = true;  // under the server's own cap, checked above
    inGate(request, [&] {
        tf = std::make_shared<TransferFunction2D>(
            transferFunction2DFromWidgets(request.body, what, ro));
    });
    auto widgets = std::make_shared<std::string>(completeWidgetJson(request.body, what, *tf));
    std::lock_guard lock(tfMutex_);
    tf2_.tf = std::move(tf);
    tf2_.widgets = std::move(widgets);
    const std::uint64_t version = ++tf2_.version;
    return jsonResponse(json{{"tf_version", version}});
}

ApiResponse Api::getTf2Row(const ApiRequest& request) {
    const Query q(request.params, {{"y", "lo", "hi", "n"}});
    const Tf2State tf2 = currentTf2();
    if (!tf2.tf) UDVR_FAIL("no 2D transfer function: start udvr serve with --tf2");
    const auto y = q.number("y", -1e300, 1e300);
    const auto lo = q.number("lo", -1e300, 1e300), hi = q.number("hi", -1e300, 1e300);
    if (!y || !lo || !hi) UDVR_FAIL("give y, lo and hi: the 2D TF along x from lo to hi at y");
    if (!(*hi > *lo)) UDVR_FAIL("hi must be above lo");
    const int n = static_cast<int>(q.whole("n", 2, kMaxTf2RowPoints).value_or(256));
    json xs = json::array(), rgba = json::array();
    for (int k = 0; k < n; ++k) {
        const double t = static_cast<double>(k) / (n - 1);
        const double x = (1.0 - t) * *lo + t * *hi;  // no overflow for any finite lo, hi
        xs.push_back(x);
        rgba.push_back(tf2.tf->colorOpacityAt(x, *y));  // bilinear, clamped (SPEC §9)
    }
    ApiResponse out = jsonResponse(json{{"y", *y}, {"x", xs}, {"rgba", rgba}});
    out.headers.emplace_back("X-Udvr-Tf-Version", std::to_string(tf2.version));
    return out;
}

}  // namespace udvr::serve
