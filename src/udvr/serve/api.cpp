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
#include "udvr/stats/value_summary.h"
#include "udvr/util/build_info.h"
#include "udvr/util/check.h"
#include "udvr/util/json_text.h"
#include "udvr/util/text_parse.h"

namespace udvr::serve {
namespace {

using nlohmann::json;

// The /api/render parameters that choose the image: "model" and every option of the library's
// tables that a server takes (render/render_options.h), by the names of `udvr render`'s flags.
const std::vector<std::string> kRenderKeys = [] {
    std::vector<std::string> keys{"model"};
    for (auto table : {classificationOptionSpecs(), frameOptionSpecs()})
        for (const OptionSpec& spec : table)
            if (spec.remote) keys.emplace_back(spec.name);
    return keys;
}();
// Parameters that steer the request, not the image.
const std::vector<std::string> kControlKeys = {"channel", "seq", "page", "source", "format"};

ApiResponse jsonResponse(const json& body, int status = 200) {
    ApiResponse r;
    r.status = status;
    r.body = body.dump(-1, ' ', false, json::error_handler_t::replace);  // bad UTF-8 → U+FFFD
    return r;
}

ApiResponse errorResponse(int status, const std::string& message) {
    return jsonResponse(json{{"error", message}}, status);
}

// The query as a map, each key at most once and from `allowed`, values of bounded length.
class Query {
  public:
    Query(const std::vector<std::pair<std::string, std::string>>& params,
          const std::vector<std::vector<std::string>>& allowed) {
        for (const auto& [key, value] : params) {
            bool known = false;
            for (const auto& list : allowed)
                known = known || std::find(list.begin(), list.end(), key) != list.end();
            if (!known) {
                std::string names;
                for (const auto& list : allowed)
                    for (const auto& k : list) names += (names.empty() ? "" : ", ") + k;
                UDVR_FAIL("unknown parameter '" << clip(key) << "' (expected: " << names << ")");
            }
            if (value.size() > kMaxValueChars)
                UDVR_FAIL("parameter '" << key << "' is longer than " << kMaxValueChars
                                        << " characters");
            if (!values_.emplace(key, value).second)
                UDVR_FAIL("parameter '" << key << "' is given twice");
        }
    }
    const std::string* find(const std::string& key) const {
        const auto it = values_.find(key);
        return it == values_.end() ? nullptr : &it->second;
    }
    bool has(const std::string& key) const { return values_.count(key) > 0; }
    std::string text(const std::string& key, const std::string& fallback = "") const {
        const std::string* v = find(key);
        return v ? *v : fallback;
    }
    /// A finite number in [lo, hi] (lo/hi exclusive when the flags say so).
    std::optional<double> number(const std::string& key, double lo, double hi,
                                 bool loOpen = false) const {
        const std::string* v = find(key);
        if (!v) return std::nullopt;
        char* end = nullptr;
        const double x = std::strtod(v->c_str(), &end);
        if (v->empty() || end != v->c_str() + v->size() || !std::isfinite(x))
            UDVR_FAIL(key << ": '" << clip(*v) << "' is not a finite number");
        if (x > hi || x < lo || (loOpen && x == lo))
            UDVR_FAIL(key << " must lie in " << (loOpen ? "(" : "[") << lo << ", " << hi
                          << "], got " << *v);
        return x;
    }
    /// A whole number in [lo, hi].
    std::optional<std::uint64_t> whole(const std::string& key, std::uint64_t lo,
                                       std::uint64_t hi) const {
        const std::string* v = find(key);
        if (!v) return std::nullopt;
        errno = 0;
        char* end = nullptr;
        const unsigned long long x = std::strtoull(v->c_str(), &end, 10);
        if (v->empty() || (*v)[0] == '-' || end != v->c_str() + v->size() || errno == ERANGE ||
            x < lo || x > hi)
            UDVR_FAIL(key << ": '" << clip(*v) << "' is not a whole number in [" << lo << ", " << hi
                          << "]");
        return x;
    }
    /// Every key of `keys` that is present, as key=value&… in the order of `keys`.
    std::string canonical(const std::vector<std::string>& keys) const {
        std::string out;
        for (const auto& k : keys)
            if (const std::string* v = find(k)) out += k + "=" + *v + "&";
        return out;
    }
    static std::string clip(const std::string& s) {
        return s.size() > 40 ? s.substr(0, 40) + "..." : s;
    }

  private:
    std::map<std::string, std::string> values_;
};

std::string pngHeaderSafe(double v) {
    char text[64];
    std::snprintf(text, sizeof text, "%.10g", v);
    return text;
}

// "a-z0-9_-", 1–32 characters: channel names.
bool isToken(const std::string& s) {
    if (s.empty() || s.size() > 32) return false;
    for (char c : s)
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_')) return false;
    return true;
}

// Whether `family` is the first row with its 1D kernel type (model_rows.h): a family's own
// model, not a view of another's (the quartiles, iqr) or an alias or a reference form of it.
// The page's probe plot shows these. (A row's factory is one function per kernel type.)
bool leadsItsKernel(const ModelFamily& family) {
    if (!family.makeKernel) return false;
    for (const ModelFamily& f : modelFamilies())
        if (f.makeKernel == family.makeKernel) return &f == &family;
    return false;
}

// The model a probe of `family` reports: itself where it has a kernel, else (gmm-mc) the first
// row with a kernel over the same arrays; null for none.
const ModelFamily* probedAs(const ModelFamily& family) {
    if (family.makeKernel) return &family;
    for (const ModelFamily& f : modelFamilies())
        if (f.makeKernel && f.arrays == family.arrays) return &f;
    return nullptr;
}

// Widget JSON as `udvr render --tf2` reads it, with the raster's domain and resolution written
// in (they may have come from --tf2-domain or --tf2-resolution, or the default resolution).
std::string completeWidgetJson(const std::string& text, const std::string& what,
                               const TransferFunction2D& tf) {
    json doc = parseJsonText(text, what);
    doc["domain"] = {tf.x0, tf.x1, tf.y0, tf.y1};
    doc["resolution"] = {tf.width, tf.height};
    return doc.dump(1, ' ', false, json::error_handler_t::replace) + "\n";
}

}  // namespace

// An image as `udvr render` writes it to PNG (8-bit values / 255), with how long it took.
struct Api::Frame {
    ImageRgba image;
    double milliseconds = 0.0;
    double rmse = -1.0;  // diff images: RMSE of the model image against the truth (SPEC §6)
};

// A parsed /api/render (or /api/probe) request.
struct Api::RenderRequest {
    ModelKind kind = ModelKind::Mean;
    RenderOptions flags;
    std::string channel = "main", source = "model";
    std::optional<std::uint64_t> seq;
    std::shared_ptr<const TransferFunction1D> tf;
    std::uint64_t tfVersion = 0;
    std::shared_ptr<const TransferFunction2D> tf2;  // with --tf2 (then tf is not used)
    std::string key;  // the image's identity: every image parameter, the TF version
};

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
               {"estimate_size", "512x512"},
               {"defaults",
                {{"size", "512x512"},
                 {"azimuth", 30.0},
                 {"elevation", 20.0},
                 {"zoom", 1.0},
                 {"realizations", RenderOptions{}.realizations}}}};
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

namespace {

// The RenderOptions of a query: each option of the library's tables by its name, parsed and
// range-checked as the CLI's flags are, then the server's own caps (size, realizations).
RenderOptions renderOptionsOf(const Query& q) {
    RenderOptions f;
    for (auto table : {classificationOptionSpecs(), frameOptionSpecs()})
        for (const OptionSpec& spec : table)
            if (const std::string* v = spec.remote ? q.find(spec.name) : nullptr)
                setOption(f, spec, *v, spec.name);
    std::array<int, 2> size{};
    try {
        size = parseSize(f.size, "size");
    } catch (const UdvrError&) {
        size = {kMaxImageSide + 1, 0};  // the message below says what is allowed
    }
    if (size[0] > kMaxImageSide || size[1] > kMaxImageSide || size[1] < 1)
        UDVR_FAIL("size must be WxH between 1x1 and " << kMaxImageSide << "x" << kMaxImageSide
                                                      << ", got '" << Query::clip(f.size) << "'");
    if (f.realizations > static_cast<std::uint64_t>(kMaxRealizations))
        UDVR_FAIL("realizations must be a whole number in [1, " << kMaxRealizations << "], got "
                                                                << f.realizations);
    checkRenderOptions(f);
    return f;
}

}  // namespace

std::shared_ptr<const Api::Frame> Api::frame(const RenderRequest& r, const std::string& source,
                                             const std::atomic<bool>& cancel) {
    const std::string key = source + "|" + r.key;
    {
        std::lock_guard lock(cacheMutex_);
        for (auto it = frames_.begin(); it != frames_.end(); ++it)
            if (it->first == key) {
                frames_.splice(frames_.begin(), frames_, it);  // most recently used first
                return it->second;
            }
    }
    auto out = std::make_shared<Frame>();
    if (source == "diff") {
        const auto model = frame(r, "model", cancel);
        const auto truth = frame(r, "truth", cancel);
        // As `udvr compare model.png truth.png --diff`: both images as their PNGs hold them.
        out->image = asWrittenToPng(differenceImage(model->image, truth->image));
        out->rmse = imageRmse(model->image, truth->image);
    } else {
        const bool truth = source == "truth";
        const ModelVolume& volume = truth ? *data_.truth : data_.model;
        const ModelKind kind = truth ? ModelKind::Mean : r.kind;
        const bool twoD = r.tf2 != nullptr;
        bool anyVisible = true;
        const auto visibleBox = [&] {
            return twoD ? visibleBounds(volume, *r.tf2, &anyVisible)
                        : visibleBounds(volume, *r.tf, &anyVisible);
        };
        std::string note;
        RenderSettings s = renderSettingsFromOptions(r.flags, volume, visibleBox, note);
        s.cancel = &cancel;
        auto& cache = renderCaches_[{source, kind}];
        if (!cache) cache = std::make_unique<RenderCache>();
        RenderStats stats;
        const ImageRgba image =
            data_.second && !truth
                ? renderBivariate(volume, *data_.second, kind, *r.tf2, s, &stats, cache.get())
            : twoD ? renderVolume(volume, kind, *r.tf2, s, &stats, cache.get())
                   : renderVolume(volume, kind, *r.tf, s, &stats, cache.get());
        out->image = asWrittenToPng(image);
        out->milliseconds = stats.milliseconds;
    }
    std::lock_guard lock(cacheMutex_);
    frames_.emplace_front(key, out);
    // At most kCachedFrames images and kCachedFrameBytes (12 of 512²: 50 MB; 2048²: 64 MB each).
    std::size_t bytes = 0;
    for (auto it = frames_.begin(); it != frames_.end(); ++it) {
        bytes += it->second->image.rgba.size() * sizeof(float);
        if (it != frames_.begin() &&
            (std::distance(frames_.begin(), it) >= static_cast<long>(kCachedFrames) ||
             bytes > kCachedFrameBytes)) {
            frames_.erase(it, frames_.end());
            break;
        }
    }
    return out;
}

ApiResponse Api::getRender(const ApiRequest& request) {
    const auto started = std::chrono::steady_clock::now();
    const Query q(request.params, {kRenderKeys, kControlKeys});
    RenderRequest r;
    r.kind = parseModelKind(q.text("model", "mean"));
    r.flags = renderOptionsOf(q);
    r.channel = q.text("channel", "main");
    if (!isToken(r.channel))
        UDVR_FAIL("channel must be 1-32 letters, digits, '-' or '_', got '"
                  << Query::clip(r.channel) << "'");
    r.seq = q.whole("seq", 0, kMaxSeq);
    // A page load's own channels: its seq counts from 1, whatever another page (or an older
    // load of this one) sent.
    if (const std::string* page = q.find("page")) {
        if (!isToken(*page))
            UDVR_FAIL("page must be 1-32 letters, digits, '-' or '_', got '" << Query::clip(*page)
                                                                             << "'");
        r.channel = *page + "/" + r.channel;
    }
    const std::string format = q.text("format", "png");
    if (format != "png" && format != "rgba")
        UDVR_FAIL("format must be png or rgba, got '" << Query::clip(format) << "'");
    r.source = q.text("source", "model");
    if (r.source != "model" && r.source != "truth" && r.source != "diff")
        UDVR_FAIL("source must be model, truth or diff, got '" << Query::clip(r.source) << "'");
    if (r.source != "model" && !data_.truth)
        UDVR_FAIL("source=" << r.source << " needs a ground truth: start udvr serve with --truth");
    std::tie(r.tf, r.tfVersion) = currentTf();
    const Tf2State tf2 = currentTf2();
    r.tf2 = tf2.tf;
    r.key = q.canonical(kRenderKeys) +
            (r.tf2 ? "tf2=" + std::to_string(tf2.version) : "tf=" + std::to_string(r.tfVersion));
    // Errors that need no rendering come before the gate: the model's arrays.
    if (r.source != "truth") checkModelHasArrays(data_.model, r.kind, ClassifyOptions{});
    std::shared_ptr<const Frame> result;
    const bool done = gate_.run(
        r.channel, r.seq,
        [&](const std::atomic<bool>& cancel) { result = frame(r, r.source, cancel); },
        request.cancel);
    if (!done) return errorResponse(409, "superseded by a newer request on channel " + r.channel);
    ApiResponse out;
    // Image bodies on their way (built, not yet taken by slow clients) are bounded: the 8-bit
    // values and their copy in the body (PNG: at most as large, with its filter bytes).
    out.hold = reserveBodies(2 * (result->image.rgba.size() + result->image.height + 1024));
    if (format == "rgba") {
        // The PNG's 8-bit values without the PNG: encoding and decoding a 512² PNG cost the page
        // ~25 ms.
        out.type = "application/octet-stream";
        const std::vector<unsigned char> bytes = pngBytes8(result->image);
        out.body.assign(bytes.begin(), bytes.end());
        out.headers.emplace_back("X-Udvr-Width", std::to_string(result->image.width));
        out.headers.emplace_back("X-Udvr-Height", std::to_string(result->image.height));
    } else {
        out.type = "image/png";
        const std::vector<unsigned char> png = encodePng(result->image, 1);
        out.body.assign(png.begin(), png.end());
    }
    out.headers.emplace_back("X-Udvr-Render-Ms", pngHeaderSafe(result->milliseconds));
    // From the request's parsing to the body ready: the render, a wait for the gate, encoding.
    const std::chrono::duration<double, std::milli> serverMs =
        std::chrono::steady_clock::now() - started;
    out.headers.emplace_back("X-Udvr-Server-Ms", pngHeaderSafe(serverMs.count()));
    out.headers.emplace_back("X-Udvr-Tf-Version",
                             std::to_string(r.tf2 ? tf2.version : r.tfVersion));
    if (result->rmse >= 0.0) out.headers.emplace_back("X-Udvr-Rmse", pngHeaderSafe(result->rmse));
    return out;
}

ApiResponse Api::getProbe(const ApiRequest& request) {
    const Query q(request.params, {kRenderKeys, {"x", "y", "point"}});
    const ModelKind kind = parseModelKind(q.text("model", "mean"));
    ClassifyOptions options;
    options.uniformMinMax = uniformWidthIsMinMax(renderOptionsOf(q));
    const auto [tf, version1D] = currentTf();
    const Tf2State tf2 = currentTf2();
    const std::uint64_t version = tf2.tf ? tf2.version : version1D;
    std::array<double, 3> point{};
    if (q.has("point")) {
        if (q.has("x") || q.has("y")) UDVR_FAIL("give either point=i,j,k or x and y, not both");
        point = parseVec3(q.text("point"), "point");
        for (int a = 0; a < 3; ++a)
            if (point[a] < 0.0 || point[a] > data_.model.grid.dims[a] - 1)
                UDVR_FAIL("point " << q.text("point") << " is outside the "
                                   << data_.model.grid.dims[0] << "x" << data_.model.grid.dims[1]
                                   << "x" << data_.model.grid.dims[2] << " grid");
    } else {
        if (!q.has("x") || !q.has("y"))
            UDVR_FAIL("give the pixel as x and y (or an index point as point=i,j,k)");
        const RenderOptions flags = renderOptionsOf(q);
        bool anyVisible = true;
        const auto visibleBox = [&] {
            return tf2.tf ? visibleBounds(data_.model, *tf2.tf, &anyVisible)
                          : visibleBounds(data_.model, *tf, &anyVisible);
        };
        std::string note;
        const RenderSettings s = renderSettingsFromOptions(flags, data_.model, visibleBox, note);
        const int x = static_cast<int>(*q.whole("x", 0, static_cast<std::uint64_t>(s.width - 1)));
        const int y = static_cast<int>(*q.whole("y", 0, static_cast<std::uint64_t>(s.height - 1)));
        // The ray's samples are classified in double precision and kept: bounded before the work
        // (render's own limit is per frame, which a 1x1 image does not bound).
        if (flags.step > 0.0) {
            const auto& b = data_.model.bounds;
            const double samples = std::hypot(b[1] - b[0], b[3] - b[2], b[5] - b[4]) / flags.step;
            if (samples > kMaxProbeRaySamples)
                UDVR_FAIL("step " << flags.step << " takes up to " << samples
                                  << " samples on the probed ray, over the limit of "
                                  << kMaxProbeRaySamples << "; give a larger step");
        }
        std::optional<std::array<double, 3>> hit;
        if (!gate_.run(
                "", std::nullopt,
                [&](const std::atomic<bool>&) {
                    hit = data_.second ? firstVisibleSampleBivariate(data_.model, *data_.second,
                                                                     kind, *tf2.tf, s, x, y)
                          : tf2.tf     ? firstVisibleSample(data_.model, kind, *tf2.tf, s, x, y)
                                       : firstVisibleSample(data_.model, kind, *tf, s, x, y);
                },
                request.cancel))
            return errorResponse(409, "cancelled");
        if (!hit)
            return errorResponse(404, "no visible sample under pixel (" + std::to_string(x) + ", " +
                                          std::to_string(y) +
                                          "): the ray misses the volume or the TF hides it");
        point = *hit;
    }
    std::optional<ProbeResult> r;
    if (!gate_.run(
            "", std::nullopt,
            [&](const std::atomic<bool>&) {
                r = data_.second
                        ? probeBivariate(data_.model, *data_.second, kind, *tf2.tf, point, options)
                    : tf2.tf ? probeModel(data_.model, kind, *tf2.tf, point, options)
                             : probeModel(data_.model, kind, *tf, point, options);
            },
            request.cancel))
        return errorResponse(409, "cancelled");
    ApiResponse out = jsonResponse(r->json);
    out.headers.emplace_back("X-Udvr-Tf-Version", std::to_string(version));
    return out;
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
