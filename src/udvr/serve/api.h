#pragma once
// The HTTP API of `udvr serve` (docs/serve.md), free of any HTTP library: a request in, a
// response out, so tests can call it directly and http_server.cpp only translates. Every
// handler parses, calls the library functions `udvr render` and `udvr probe` call, and answers;
// bad input is a 4xx with a one-line message, never a crash. No request names a file.
#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "udvr/classify/model_kind.h"
#include "udvr/classify/transfer_function.h"
#include "udvr/classify/transfer_function_2d.h"
#include "udvr/io/image.h"
#include "udvr/render/frame_estimate.h"
#include "udvr/render/render.h"
#include "udvr/serve/render_gate.h"
#include "udvr/stats/model_volume.h"

namespace udvr::serve {

/// What `udvr serve` was started with (read once; the TF changes through POST /api/tf).
struct ServeData {
    ModelVolume model;
    std::string modelFile;  // as given on the command line (for the page's `udvr render` line)
    std::optional<ModelVolume> truth;  // --truth: the ground-truth field, rendered as `mean`
    std::string truthFile;
    std::optional<ModelVolume> second;  // --second: field 2 of a bivariate 2D TF
    std::string secondFile;
    TransferFunction1D tf;                  // the starting 1D TF
    std::optional<TransferFunction2D> tf2;  // --tf2: renders use it instead of the 1D TF
    std::string tf2File;
    /// --tf2 as widget JSON: the file's text (editable on the page); empty for a raster TF2.
    std::string tf2Widgets;
    std::size_t maxBodyBytes = 1 << 20;  // POST bodies (--max-body)
};

struct ApiRequest {
    std::string method = "GET", path;
    std::vector<std::pair<std::string, std::string>> params;  // query, in order (repeats kept)
    std::string body;
    /// Set when the client has gone: the request's work is cancelled (null: never).
    std::shared_ptr<std::atomic<bool>> cancel;
};

struct ApiResponse {
    int status = 200;
    std::string type = "application/json";
    std::string body;
    std::vector<std::pair<std::string, std::string>> headers;
    /// Held until the body has been sent (its bytes count against kMaxBodyBytesInFlight).
    std::shared_ptr<void> hold;
};

/// Thrown when a request must wait for memory others hold: 503.
struct Busy : std::runtime_error {
    using std::runtime_error::runtime_error;
};

/// Limits on what a request may ask.
inline constexpr int kMaxImageSide = 2048;             // pixels per side of /api/render
inline constexpr int kMaxRealizations = 1000;          // gmm-mc
inline constexpr std::size_t kMaxBodyBytes = 1 << 20;  // POST bodies (TF JSON)
inline constexpr std::size_t kMaxValueChars = 256;     // one query value
inline constexpr int kMaxHistogramBins = 4096;
inline constexpr int kMaxHistogram2DBins = 1024;      // per axis of /api/histogram2d
inline constexpr int kMaxPostedTf2Resolution = 1024;  // raster points per axis of POST /api/tf2
inline constexpr std::size_t kMaxPostedTf2Widgets = 256;
inline constexpr int kMaxTf2RowPoints = 4096;  // points of GET /api/tf2/row
/// Raster points × widget terms (a band counts its segments) of POST /api/tf2: 256 widgets at
/// 1024² (about 1 s on one core).
inline constexpr double kMaxPostedTf2Work = 1 << 28;
/// Samples on the ray of /api/probe?x=&y= (each classified in double precision and kept).
inline constexpr double kMaxProbeRaySamples = 1 << 20;
/// seq of /api/render: JavaScript's largest exact integer, 2^53 − 1.
inline constexpr std::uint64_t kMaxSeq = (std::uint64_t{1} << 53) - 1;
/// Images the server keeps (the difference image reuses the model and truth frames).
inline constexpr std::size_t kCachedFrames = 12;
inline constexpr std::size_t kCachedFrameBytes = std::size_t{256} << 20;
/// Bytes of image bodies built and not yet sent (slow clients hold theirs): over it, 503.
inline constexpr std::size_t kMaxBodyBytesInFlight = std::size_t{512} << 20;
/// Freed blocks of this size and more go back to the system at once (runHttpServer: mallopt).
inline constexpr std::size_t kReturnedBlockBytes = std::size_t{1} << 20;
/// The latency goal of a frame: a model whose frame at the page's default view (512², SPEC §5's
/// camera, the current TF) is estimated over it is marked `slow` in /api/state, and the page
/// renders it progressively (coarse first, each step cancelled by the next request).
inline constexpr double kFrameGoalMs = 1000.0;
/// /api/state's per-model estimates (render/frame_estimate.h): no probe over kEstimateProbeMs,
/// and at most kEstimateDeadlineMs of probes per model (past it the estimate is a lower bound
/// and the model counts as slow),
/// so one /api/state costs at most (models) × kEstimateDeadlineMs of render time. They are
/// kept for the current TF only (one per model).
inline constexpr double kEstimateProbeMs = 200.0;
inline constexpr double kEstimateDeadlineMs = 600.0;

class Api {
  public:
    explicit Api(ServeData data);
    ~Api();
    Api(const Api&) = delete;
    Api& operator=(const Api&) = delete;

    /// Answer one request; never throws (errors are 4xx/5xx responses with {"error": …}).
    ApiResponse handle(const ApiRequest& request);

    /// The render gate's counts (GET /api/status).
    RenderGate::Stats gateStats() const { return gate_.stats(); }

  private:
    struct Frame;
    struct RenderRequest;

    ApiResponse route(const ApiRequest& request);
    ApiResponse getState(const ApiRequest& request);
    /// The estimated default frame of each model (kind → estimate; absent: not available),
    /// probed for the current TF in a turn of the gate when not yet known.
    std::map<ModelKind, FrameEstimate> frameEstimates(const ApiRequest& request,
                                                      const std::vector<ModelKind>& kinds);
    ApiResponse getRender(const ApiRequest& request);
    ApiResponse getProbe(const ApiRequest& request);
    ApiResponse getHistogram(const ApiRequest& request);
    ApiResponse getTf();
    ApiResponse postTf(const ApiRequest& request);
    ApiResponse getPreset(const ApiRequest& request);
    ApiResponse getHistogram2D(const ApiRequest& request);
    ApiResponse getTf2();
    ApiResponse postTf2(const ApiRequest& request);
    ApiResponse getTf2Row(const ApiRequest& request);
    ApiResponse getStatus();
    /// Run heavy work in a turn of the render gate (no channel); throws RenderCancelled when its
    /// client has gone before or while it ran.
    void inGate(const ApiRequest& request, const std::function<void()>& work);
    /// Count `bytes` of a body against kMaxBodyBytesInFlight until the token is dropped; throws
    /// Busy over it (unless nothing else is on its way).
    std::shared_ptr<void> reserveBodies(std::size_t bytes);

    /// The current 1D TF and its version (each POST /api/tf makes a new one).
    std::pair<std::shared_ptr<const TransferFunction1D>, std::uint64_t> currentTf() const;
    /// The current 2D TF (null without --tf2), its widget JSON (empty for a raster) and version.
    struct Tf2State {
        std::shared_ptr<const TransferFunction2D> tf;
        std::shared_ptr<const std::string> widgets;
        std::uint64_t version = 0;
    };
    Tf2State currentTf2() const;
    /// The image of `source` ("model" or "truth") for the request: from the cache, or rendered
    /// (inside the gate; throws RenderCancelled when `cancel` turns true).
    std::shared_ptr<const Frame> frame(const RenderRequest& r, const std::string& source,
                                       const std::atomic<bool>& cancel);

    ServeData data_;
    RenderGate gate_;
    std::atomic<std::size_t> bodyBytes_{0};
    mutable std::mutex tfMutex_;
    std::shared_ptr<const TransferFunction1D> tf_;
    std::uint64_t tfVersion_ = 1;
    Tf2State tf2_;  // under tfMutex_
    std::mutex gradientMutex_;
    std::vector<float> gradientMagnitudes_;  // of the model's means, computed on first use
    std::mutex cacheMutex_;
    std::list<std::pair<std::string, std::shared_ptr<const Frame>>> frames_;  // newest first
    // Skipping tables per (source, model kind); used only inside the gate (one render at once).
    std::map<std::pair<std::string, ModelKind>, std::unique_ptr<RenderCache>> renderCaches_;
    std::mutex estimatesMutex_;
    std::string estimatesTf_;  // the TF versions the estimates are for
    std::map<ModelKind, FrameEstimate> estimates_;
};

}  // namespace udvr::serve
