// `udvr serve`'s render endpoints: /api/render (the frame cache, the render gate) and /api/probe
// (a pixel's first visible sample, or an index point).
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

}  // namespace udvr::serve
