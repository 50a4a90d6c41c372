// `udvr serve`'s API: construction, the dispatch of a request to its endpoint, /api/state (the
// models, their estimates) and /api/status. Renders and probes: api_render.cpp; the TFs and
// histograms: api_tf.cpp; what they share (query parsing, JSON answers): api_query.h.
#include "udvr/serve/api.h"

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
#include "udvr/serve/api_query.h"
#include "udvr/stats/value_summary.h"
#include "udvr/util/build_info.h"
#include "udvr/util/check.h"
#include "udvr/util/json_text.h"
#include "udvr/util/text_parse.h"

namespace udvr::serve {
namespace {

using nlohmann::json;

// Whether `family` is the first row with its 1D kernel type (model_rows.h): a family's own
// model, not a view of another's (the quartiles, iqr) or an alias or a reference form of it.
// The page's probe plot shows these. (A row's factory is one function per kernel type.)
bool leadsItsKernel(const ModelFamily& family) {
    if (!family.makeKernel) return false;
    for (const ModelFamily& f : modelFamilies())
        if (f.makeKernel == family.makeKernel) return &f == &family;
    return false;
}

// The model the page starts on: the first available one that classifies by the whole quantile
// population (Eq. 4, the paper's nonparametric model: quantile-range), else the first available
// row (the mean field where its array is there), else the table's first row.
std::string_view startModelOf(const std::vector<ModelKind>& available) {
    for (ModelKind kind : available) {
        const auto [lo, hi] = modelFamily(kind).population;
        if (lo == 0.0 && hi == 1.0) return modelFamily(kind).name;
    }
    return modelFamily(available.empty() ? allModelKinds().front() : available.front()).name;
}

// The model a probe of `family` reports: itself where it has a kernel, else (gmm-mc) the first
// row with a kernel over the same arrays; null for none.
const ModelFamily* probedAs(const ModelFamily& family) {
    if (family.makeKernel) return &family;
    for (const ModelFamily& f : modelFamilies())
        if (f.makeKernel && f.arrays == family.arrays) return &f;
    return nullptr;
}

}  // namespace

Api::Api(ServeData data)
    : data_(std::move(data)), tf_(std::make_shared<TransferFunction1D>(data_.tf)) {
    tf_->validate();
    if (data_.tf2) {
        data_.tf2->validate();
        tf2_.tf = std::make_shared<TransferFunction2D>(*data_.tf2);
        tf2_.version = 1;
        if (!data_.tf2Widgets.empty())
            tf2_.widgets = std::make_shared<std::string>(
                completeWidgetJson(data_.tf2Widgets, data_.tf2File, *data_.tf2));
    }
}

Api::~Api() = default;

std::pair<std::shared_ptr<const TransferFunction1D>, std::uint64_t> Api::currentTf() const {
    std::lock_guard lock(tfMutex_);
    return {tf_, tfVersion_};
}

Api::Tf2State Api::currentTf2() const {
    std::lock_guard lock(tfMutex_);
    return tf2_;
}

ApiResponse Api::handle(const ApiRequest& request) {
    try {
        return route(request);
    } catch (const RenderCancelled&) {
        return errorResponse(409, "superseded by a newer request on this channel");
    } catch (const UdvrError& e) {
        return errorResponse(400, e.what());
    } catch (const std::bad_alloc&) {
        return errorResponse(503, "out of memory");
    } catch (const Busy& e) {
        return errorResponse(503, e.what());
    } catch (const std::exception& e) {
        return errorResponse(500, std::string("internal error: ") + e.what());
    } catch (...) {
        return errorResponse(500, "internal error");
    }
}

ApiResponse Api::route(const ApiRequest& request) {
    const std::string& p = request.path;
    const bool get = request.method == "GET", post = request.method == "POST";
    if (p == "/api/state" && get) return getState(request);
    if (p == "/api/render" && get) return getRender(request);
    if (p == "/api/probe" && get) return getProbe(request);
    if (p == "/api/histogram" && get) return getHistogram(request);
    if (p == "/api/tf" && get) return getTf();
    if (p == "/api/tf" && post) return postTf(request);
    if (p == "/api/preset" && get) return getPreset(request);
    if (p == "/api/status" && get) return getStatus();
    if (p == "/api/histogram2d" && get) return getHistogram2D(request);
    if (p == "/api/tf2" && get) return getTf2();
    if (p == "/api/tf2" && post) return postTf2(request);
    if (p == "/api/tf2/row" && get) return getTf2Row(request);
    for (const char* known :
         {"/api/state", "/api/render", "/api/probe", "/api/histogram", "/api/tf", "/api/preset",
          "/api/status", "/api/histogram2d", "/api/tf2", "/api/tf2/row"})
        if (p == known) return errorResponse(405, "method " + request.method + " not allowed");
    return errorResponse(404, "no such endpoint: " + Query::clip(p));
}

ApiResponse Api::getState(const ApiRequest& request) {
    const ModelVolume& m = data_.model;
    json models = json::array();
    std::vector<ModelKind> available;
    for (ModelKind kind : allModelKinds()) {
        const ModelFamily& family = modelFamily(kind);
        json row{{"name", std::string(family.name)}};
        std::string label(family.name);
        if (family.labelShowsQ && m.quantileCount > 0)
            label += " (q=" + std::to_string(m.quantileCount) + ")";
        if (readsGmm(kind))
            if (m.gmmComponents > 0) label += " (K=" + std::to_string(m.gmmComponents) + ")";
        row["label"] = label;
        std::string reason;
        try {
            checkModelHasArrays(m, kind, ClassifyOptions{});
            if (data_.tf2 && !family.makeKernel2D && !(data_.second && family.makeBivariate))
                reason = "no 2D transfer-function classification for this model";
        } catch (const UdvrError& e) {
            reason = e.what();
        }
        if (reason.empty() && data_.second) {  // bivariate renders need its arrays too
            try {
                checkModelHasArrays(*data_.second, kind, ClassifyOptions{});
            } catch (const UdvrError& e) {
                reason = "--second " + data_.secondFile + ": " + e.what();
            }
        }
        row["available"] = reason.empty();
        if (!reason.empty()) row["reason"] = reason;
        if (reason.empty()) available.push_back(kind);
        row["probe"] = !family.realizations;
        const ModelFamily* probed = probedAs(family);
        row["probe_as"] = probed ? json(std::string(probed->name)) : json(nullptr);
        row["plot"] = leadsItsKernel(family);
        // The rank interval a quantile-range-family model covers (SPEC §4): the page's quartile
        // view is the available models whose intervals are proper parts of [0, 1].
        row["population"] = family.population.second > family.population.first
                                ? json::array({family.population.first, family.population.second})
                                : json(nullptr);
        // Averaged realizations (gmm-mc): its cost is per realization, so its progressive steps
        // (the page) cut the realizations rather than the image.
        row["realizations"] = family.realizations;
        models.push_back(row);
    }
    // Each available model's frame at the default view, estimated (cost before work, issue 35):
    // probed with ?estimates=1 (the page), else only those already known for the current TF, so
    // a plain /api/state never waits for the render gate.
    const Query q(request.params, {{"estimates"}});
    const std::string want = q.text("estimates", "0");
    if (want != "0" && want != "1")
        UDVR_FAIL("estimates must be 0 or 1, got '" << Query::clip(want) << "'");
    std::map<ModelKind, FrameEstimate> estimates;
    if (want == "1") {
        estimates = frameEstimates(request, available);
    } else if (std::unique_lock lock(estimatesMutex_, std::try_to_lock); lock.owns_lock()) {
        const auto [tf1, v1] = currentTf();
        if (estimatesTf_ == std::to_string(v1) + "/" + std::to_string(currentTf2().version))
            estimates = estimates_;
    }
    for (json& row : models) {
        const auto it = estimates.find(parseModelKind(row["name"].get<std::string>()));
        if (it == estimates.end() || it->second.ms <= 0.0) {
            row["estimate_ms"] = nullptr;
            row["slow"] = false;
            continue;
        }
        row["estimate_ms"] = std::round(it->second.ms);
        row["estimate_lower_bound"] = it->second.lowerBound;
        // A probe stopped by the deadline: slow (its 1/32-side probe alone took 0.6 s).
        row["slow"] = it->second.lowerBound || it->second.ms > kFrameGoalMs;
    }
    const auto [tf, version] = currentTf();
    const Tf2State tf2 = currentTf2();
    const std::string startModel(startModelOf(available));
    const RenderOptions defaults;  // `udvr render`'s: the page starts from them
    json presets = json::array();
    for (const auto& name : transferFunctionPresetNames()) presets.push_back(name);
    json state{{"version", std::string(build::versionLine())},
               {"model",
                {{"file", data_.modelFile},
                 {"dims", m.grid.dims},
                 {"origin", m.grid.origin},
                 {"spacing", m.grid.spacing},
                 {"bounds", m.bounds},
                 {"quantiles", m.quantileCount},
                 {"gmm_components", m.gmmComponents},
                 {"density", m.density},
                 {"samples_per_voxel", m.samplesPerVoxel},
                 {"downsample", m.downsample}}},
               {"models", models},
               {"truth", data_.truth ? json(data_.truthFile) : json(nullptr)},
               {"second", data_.second ? json(data_.secondFile) : json(nullptr)},
               {"tf2", data_.tf2 ? json(data_.tf2File) : json(nullptr)},
               {"tf2_editable", tf2.widgets != nullptr},  // widget JSON (a raster is view-only)
               {"tf2_version", tf2.version},
               {"tf_version", version},
               {"presets", presets},
               {"limits", {{"max_side", kMaxImageSide}, {"max_realizations", kMaxRealizations}}},
               {"latency_goal_ms", kFrameGoalMs},
               {"estimate_size", defaults.size},
               {"defaults",
                {{"model", startModel},
                 {"size", defaults.size},
                 {"azimuth", defaults.azimuth},
                 {"elevation", defaults.elevation},
                 {"zoom", defaults.zoom},
                 {"realizations", defaults.realizations}}}};
    return jsonResponse(state);
}

std::map<ModelKind, FrameEstimate> Api::frameEstimates(const ApiRequest& request,
                                                       const std::vector<ModelKind>& kinds) {
    const auto [tf, version1D] = currentTf();
    const Tf2State tf2 = currentTf2();
    const std::string versions = std::to_string(version1D) + "/" + std::to_string(tf2.version);
    std::lock_guard lock(estimatesMutex_);  // one /api/state probes at a time
    if (estimatesTf_ != versions) {         // kept for the current TF only
        estimates_.clear();
        estimatesTf_ = versions;
    }
    std::vector<ModelKind> missing;
    for (ModelKind kind : kinds)
        if (!estimates_.count(kind)) missing.push_back(kind);
    if (missing.empty()) return estimates_;
    inGate(request, [&] {
        // The page's default view: `udvr render`'s defaults (512², SPEC §5's camera).
        RenderOptions flags;
        std::string note;
        bool anyVisible = true;
        RenderSettings s = renderSettingsFromOptions(
            flags, data_.model,
            [&] {
                return tf2.tf ? visibleBounds(data_.model, *tf2.tf, &anyVisible)
                              : visibleBounds(data_.model, *tf, &anyVisible);
            },
            note);
        s.cancel = request.cancel.get();  // a client that goes stops the probes
        FrameEstimateLimits limits;
        limits.maxProbeMs = kEstimateProbeMs;
        limits.deadlineMs = kEstimateDeadlineMs;
        for (ModelKind kind : missing) {
            auto& cache = renderCaches_[{"model", kind}];
            if (!cache) cache = std::make_unique<RenderCache>();
            estimates_[kind] = estimateFrame(
                s, rendersRealizations(kind),
                [&](const RenderSettings& at) {
                    RenderStats stats;
                    if (data_.second)
                        renderBivariate(data_.model, *data_.second, kind, *tf2.tf, at, &stats,
                                        cache.get());
                    else if (tf2.tf)
                        renderVolume(data_.model, kind, *tf2.tf, at, &stats, cache.get());
                    else
                        renderVolume(data_.model, kind, *tf, at, &stats, cache.get());
                    return stats.milliseconds;
                },
                limits);
        }
    });
    return estimates_;
}

std::shared_ptr<void> Api::reserveBodies(std::size_t bytes) {
    std::size_t now = bodyBytes_.load();
    do
        if (now > 0 && now + bytes > kMaxBodyBytesInFlight)
            throw Busy("busy: " + std::to_string(now >> 20) +
                       " MiB of images are on their way to clients; try again");
    while (!bodyBytes_.compare_exchange_weak(now, now + bytes));
    return std::shared_ptr<void>(nullptr, [this, bytes](void*) { bodyBytes_ -= bytes; });
}

void Api::inGate(const ApiRequest& request, const std::function<void()>& work) {
    if (!gate_.run(
            "", std::nullopt, [&](const std::atomic<bool>&) { work(); }, request.cancel))
        throw RenderCancelled();
}

ApiResponse Api::getStatus() {
    const RenderGate::Stats s = gate_.stats();
    return jsonResponse(json{{"completed", s.completed},
                             {"cancelled", s.cancelled},
                             {"superseded", s.superseded},
                             {"abandoned", s.abandoned},
                             {"evicted", s.evicted},
                             {"channels", s.channels},
                             {"running", s.running},
                             {"waiting", s.waiting}});
}

}  // namespace udvr::serve
