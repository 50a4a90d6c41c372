// udvr render {field|model.vti|ensemble --model members} --model NAME {--tf tf.json | --tf2 TF2}
//             [--size WxH] [camera…] [--step S] [--unit-distance U] [--float img.npy|.pfm]
//             [--frames N] [--memory-cap GIB] -o img.png   (SPEC §8)
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "udvr/classify/model_kind.h"
#include "udvr/cmd/commands.h"
#include "udvr/cmd/parse_util.h"
#include "udvr/io/field_io.h"
#include "udvr/io/image.h"
#include "udvr/io/model_io.h"
#include "udvr/io/transfer_function_io.h"
#include "udvr/render/framing.h"
#include "udvr/render/render.h"
#include "udvr/stats/model_volume.h"
#include "udvr/util/check.h"
#include "udvr/util/parallel.h"

namespace udvr::cmd {
namespace {

struct RenderOpts {
    std::vector<std::string> inputs;  // one model or field; an ensemble for --model members
    std::string model = "mean", size = "512x512", out, floatOut;
    TfFlags tf;               // 1D TF: file or preset (default: a preset over the data)
    std::string view, frame;  // framed default camera (render/framing.h)
    bool force = false;
    std::string position, focal, up, background, uniformWidth = "variance";
    double viewAngle = 30.0, parallelScale = 0.0, azimuth = 30.0, elevation = 20.0, zoom = 1.0;
    double step = 0.0, unit = 0.0, earlyExit = 0.99;
    bool noSkip = false;
    int realizations = 200, frames = 0;
    std::uint64_t seed = 1, jitter = 0;
    Tf2Flags tf2;        // 2D TF (SPEC §9)
    RawLayoutFlags raw;  // headerless .raw input
    std::string var;
    std::string second, secondVar;  // bivariate fields (SPEC §9 --second)
    EnsembleFlags ensemble;         // --model members
};

// More samples than this per frame (an upper bound: every ray crossing the box's diagonal)
// from an explicit --step asks for --force.
constexpr double kMaxSamplesWithoutForce = 1e9;
// Larger images (rays per frame) ask for --force too: 8192² floats are 1 GiB of image.
constexpr double kMaxPixelsWithoutForce = 8192.0 * 8192.0;

// The camera: --position (SPEC §5) as given; else SPEC §5's default camera when a TF was given
// and neither --view nor --frame was; else a camera framing the visible part of the volume
// (or, --frame box, all of it) from --view or the z-up front view.
Camera cameraFromOptions(const RenderOpts& o, const ModelVolume& m, bool tfGiven,
                         const std::function<std::array<double, 6>()>& visibleBox, double aspect,
                         bool azimuthGiven, bool elevationGiven, std::string& note) {
    const auto& b = m.bounds;
    if (!o.frame.empty() && o.frame != "box" && o.frame != "visible")
        UDVR_FAIL("--frame must be 'visible' or 'box', got '" << o.frame << "'");
    if (!o.position.empty() && (!o.view.empty() || !o.frame.empty()))
        UDVR_FAIL("--view and --frame choose the default camera; they do not go with --position");
    if (o.position.empty()) {
        if (!o.focal.empty() || !o.up.empty())
            UDVR_FAIL("--focal-point/--view-up need --position (or use --azimuth/--elevation)");
        const bool framed = !o.view.empty() || !o.frame.empty() || !tfGiven;
        Camera c;
        if (!framed) {
            c = defaultCamera(b, o.azimuth, o.elevation, o.zoom, o.viewAngle);
        } else {
            const auto box = o.frame == "box" ? b : visibleBox();
            const ViewDirection view = o.view.empty() ? kZUpFrontView : parseViewDirection(o.view);
            // The front view is turned to a three-quarter view unless told otherwise; an axis
            // view looks straight along its axis.
            const double az = azimuthGiven ? o.azimuth : (o.view.empty() ? 30.0 : 0.0);
            const double el = elevationGiven ? o.elevation : (o.view.empty() ? 20.0 : 0.0);
            c = framedCamera(box, view, az, el, o.zoom, o.viewAngle, aspect);
            char text[256];
            std::snprintf(text, sizeof text,
                          "render: camera frames %s [%.6g, %.6g] x [%.6g, %.6g] x [%.6g, %.6g] "
                          "(--frame box: the whole volume; --position: your own)",
                          o.frame == "box" ? "the volume" : "the visible voxels", box[0], box[1],
                          box[2], box[3], box[4], box[5]);
            note = text;
        }
        if (o.parallelScale > 0.0) {
            c.parallel = true;
            c.parallelScale = o.parallelScale;
        }
        return c;
    }
    Camera c;
    c.position = parseVec3(o.position, "--position");
    c.focalPoint = o.focal.empty() ? std::array<double, 3>{0.5 * (b[0] + b[1]), 0.5 * (b[2] + b[3]),
                                                           0.5 * (b[4] + b[5])}
                                   : parseVec3(o.focal, "--focal-point");
    c.viewUp = o.up.empty() ? std::array<double, 3>{0.0, 1.0, 0.0} : parseVec3(o.up, "--view-up");
    c.viewAngleDeg = o.viewAngle;
    if (o.parallelScale > 0.0) {
        c.parallel = true;
        c.parallelScale = o.parallelScale;
    }
    return c;
}

void run(const RenderOpts& o, bool jitterGiven, bool parallelGiven, bool azimuthGiven,
         bool elevationGiven) {
    if (parallelGiven && !(o.parallelScale > 0.0))
        UDVR_FAIL("--parallel-scale must be > 0, got " << o.parallelScale);
    if (o.frames < 0) UDVR_FAIL("--frames must be >= 0, got " << o.frames);
    const std::string outExt = lowerExtension(o.out);
    if (outExt != ".png") UDVR_FAIL("-o must name a .png file, got '" << o.out << "'");
    if (!o.floatOut.empty()) {
        const std::string e = lowerExtension(o.floatOut);
        if (e != ".npy" && e != ".pfm")
            UDVR_FAIL("--float must name a .npy or .pfm file, got '" << o.floatOut << "'");
        requireOutputDirectory(o.floatOut, "--float");
    }
    requireOutputDirectory(o.out, "-o");
    const ModelKind kind = parseModelKind(o.model);
    requireOneTf(o.tf.tf, o.tf2);
    const bool twoD = !o.tf2.file.empty();
    const bool members = kind == ModelKind::Members;
    if (!members && o.inputs.size() != 1)
        UDVR_FAIL("render takes one model or field, got "
                  << o.inputs.size()
                  << " inputs (member files are an ensemble: --model members renders its members' "
                     "average classification, `udvr build` models it)");
    if (members && twoD)
        UDVR_FAIL("--model members classifies with a 1D transfer function (--tf), not --tf2");
    const std::string& input = o.inputs.front();
    checkTfFlags(o.tf, twoD);
    const auto size = parseSize(o.size, "--size");
    if (static_cast<double>(size[0]) * size[1] > kMaxPixelsWithoutForce && !o.force)
        UDVR_FAIL("--size " << o.size << " is over " << kMaxPixelsWithoutForce / 1e6
                            << " million rays per frame; add --force to render anyway");
    // Cheap camera flags are checked before the volume is read.
    if (!o.frame.empty() && o.frame != "box" && o.frame != "visible")
        UDVR_FAIL("--frame must be 'visible' or 'box', got '" << o.frame << "'");
    if (!o.view.empty()) parseViewDirection(o.view);
    const bool tfGiven = twoD || !tfIsPreset(o.tf);
    // A TF file is read before the volume, so a bad one costs nothing; a preset needs the data.
    TfChoice tfChoice;
    if (!twoD && tfGiven) tfChoice.tf = readTransferFunctionFile(o.tf);
    const TransferFunction2D tf2 =
        twoD ? readTransferFunction2D(o.tf2.file, toTf2ReadOptions(o.tf2)) : TransferFunction2D{};
    if (!o.second.empty() && !twoD)
        UDVR_FAIL("--second gives the y of a 2D transfer function: it needs --tf2");
    const ModelVolume model = members ? readMembersModel(o.inputs, o.var, o.raw, o.ensemble)
                                      : readModelOrField(input, o.var, o.raw);
    if (!twoD && !tfGiven) tfChoice = chooseTransferFunction(o.tf, model.mean, "render");
    const TransferFunction1D& tf = tfChoice.tf;
    const ModelVolume second =
        o.second.empty()
            ? ModelVolume{}
            : readModelOrField(o.second, o.secondVar.empty() ? o.var : o.secondVar, o.raw);

    RenderSettings s;
    s.width = size[0];
    s.height = size[1];
    if (o.step > 0.0 && !o.force) {
        const auto& b = model.bounds;
        const double diagonal = std::hypot(b[1] - b[0], b[3] - b[2], b[5] - b[4]);
        const double samples = static_cast<double>(s.width) * s.height * (diagonal / o.step);
        if (samples > kMaxSamplesWithoutForce)
            UDVR_FAIL("--step " << o.step << " takes up to " << samples << " samples per frame ("
                                << s.width << "x" << s.height << " rays, up to "
                                << diagonal / o.step
                                << " samples each); add --force to render anyway");
    }
    bool anyVisible = true;
    std::array<double, 6> framedBox{};  // what the framed camera fits (when it is used)
    const auto visibleBox = [&] {
        framedBox =
            twoD ? visibleBounds(model, tf2, &anyVisible) : visibleBounds(model, tf, &anyVisible);
        return framedBox;
    };
    std::string cameraNote;
    s.camera =
        cameraFromOptions(o, model, tfGiven, visibleBox, static_cast<double>(s.width) / s.height,
                          azimuthGiven, elevationGiven, cameraNote);
    s.step = o.step;
    s.unitDistance = o.unit;
    s.earlyExit = o.earlyExit;
    if (!o.background.empty()) {
        const auto bg = parseVec3(o.background, "--background");
        for (int c = 0; c < 3; ++c) s.background[c] = static_cast<float>(bg[c]);
    }
    s.skipEmpty = !o.noSkip;
    s.uniformMinMax = parseUniformWidthMinMax(o.uniformWidth);
    s.realizations = o.realizations;
    s.seed = o.seed;
    if (jitterGiven) s.jitterSeed = o.jitter;

    RenderStats stats;
    RenderCache cache;  // skipping tables built by the first frame, reused by the timed ones
    const auto frame = [&] {
        if (!o.second.empty()) return renderBivariate(model, second, kind, tf2, s, &stats, &cache);
        return twoD ? renderVolume(model, kind, tf2, s, &stats, &cache)
                    : renderVolume(model, kind, tf, s, &stats, &cache);
    };
    ImageRgba image = frame();
    if (o.frames > 0) {
        // The render above was the warm-up; time N more frames (loading is not counted).
        std::vector<double> ms;
        for (int f = 0; f < o.frames; ++f) {
            image = frame();
            ms.push_back(stats.milliseconds);
        }
        std::vector<double> sorted = ms;
        std::sort(sorted.begin(), sorted.end());
        const std::size_t n = sorted.size();
        const double median = n % 2 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
        std::printf("frames      %zu: median %.1f ms  min %.1f ms  max %.1f ms  -> %.2f frames/s\n",
                    n, median, sorted.front(), sorted.back(), 1000.0 / median);
        std::printf(
            "RESULT renderer=udvr model=%s dims=%dx%dx%d size=%dx%d threads=%d "
            "sd=%.6g median_ms=%.2f min_ms=%.2f max_ms=%.2f fps=%.3f\n",
            std::string(modelName(kind)).c_str(), model.grid.dims[0], model.grid.dims[1],
            model.grid.dims[2], s.width, s.height, threadCount(),
            s.step > 0 ? s.step : 0.5 * model.fullResMinSpacing, median, sorted.front(),
            sorted.back(), 1000.0 / median);
        std::fflush(stdout);
    }
    finishTransferFunction(o.tf, tfChoice);  // --save-tf first: a bad one leaves no image
    if (!o.floatOut.empty()) writeFloatImage(o.floatOut, image);
    writePng(o.out, image);
    if (!cameraNote.empty()) {
        const bool wholeBox = anyVisible && framedBox == model.bounds;
        if (!anyVisible) {
            const std::string visible = "the visible voxels";
            const auto at = cameraNote.find(visible);
            if (at != std::string::npos)
                cameraNote.replace(at, visible.size(), "the whole volume (nothing is visible)");
        }
        std::fprintf(stderr, "%s\n", cameraNote.c_str());
        if (!anyVisible)
            std::fprintf(stderr,
                         "udvr: warning: the TF gives no voxel an opacity of 10 %% of its largest: "
                         "the image shows little or nothing (udvr info %s --histogram h.png "
                         "shows the values)\n",
                         input.c_str());
        else if (wholeBox && !tfGiven)
            std::fprintf(stderr,
                         "render: the preset shows voxels out to the volume's faces, which may "
                         "hide the inside: --tf-range lo,hi or a TF file with opacity 0 at their "
                         "values shows it (udvr info %s --histogram h.png shows the values)\n",
                         input.c_str());
    }
    const auto& cam = s.camera;
    std::fprintf(stderr,
                 "render: camera pos %.6g %.6g %.6g  focal %.6g %.6g %.6g  up %.6g %.6g %.6g  %s "
                 "%.6g\n",
                 cam.position[0], cam.position[1], cam.position[2], cam.focalPoint[0],
                 cam.focalPoint[1], cam.focalPoint[2], cam.viewUp[0], cam.viewUp[1], cam.viewUp[2],
                 cam.parallel ? "parallel-scale" : "view-angle",
                 cam.parallel ? cam.parallelScale : cam.viewAngleDeg);

    std::fprintf(stderr, "render: %s %dx%d in %.1f ms, %llu samples (%llu skipped) -> %s\n",
                 std::string(modelName(kind)).c_str(), s.width, s.height, stats.milliseconds,
                 static_cast<unsigned long long>(stats.samples),
                 static_cast<unsigned long long>(stats.skippedSamples), o.out.c_str());
}

}  // namespace

void addRenderCommand(CLI::App& app) {
    auto* sub = app.add_subcommand(
        "render", "ray-cast a field or a model volume with a transfer function (SPEC §5)");
    auto o = std::make_shared<RenderOpts>();
    sub->add_option("input", o->inputs,
                    "model .vti from 'udvr build', or any scalar field; with --model members an "
                    "ensemble (.nc with a member dimension, member files or a quoted glob)")
        ->required();
    sub->add_option(
        "--model", o->model,
        "mean | uniform | uniform-exact | gaussian | gmm-ordered | gmm-mc | quantile-range | "
        "quantile-mean | quantile-mean-mass | iqr | quartile-lower|middle|upper | "
        "members (an ensemble's TF averaged over its members; default mean)");
    addTfOptions(sub, o->tf);
    sub->add_option("--tf2", o->tf2.file,
                    "2D transfer function over value x gradient magnitude (.vti, .npy, widget "
                    ".json; SPEC 9)");
    addTf2FormOptions(sub, o->tf2);
    sub->add_option("--second", o->second,
                    "bivariate fields: the model or field giving the TF2's y (same grid; x from "
                    "the input; SPEC 9)");
    sub->add_option("--second-var", o->secondVar,
                    "array/variable name in --second (default: --var)");
    sub->add_option("-o,--output", o->out, "output PNG")->required();
    sub->add_option("--size", o->size, "image size WxH (default 512x512)");
    sub->add_option("--float", o->floatOut, "also write float32 RGBA (.npy or .pfm)");
    sub->add_option("--position", o->position, "camera position x,y,z (world units)");
    sub->add_option("--focal-point", o->focal, "focal point x,y,z (default: box centre)");
    sub->add_option("--view-up", o->up, "view-up x,y,z (default 0,1,0)");
    sub->add_option("--view-angle", o->viewAngle, "vertical view angle, degrees (default 30)");
    auto* ps = sub->add_option("--parallel-scale", o->parallelScale,
                               "orthographic: half the view height, world units");
    auto* az = sub->add_option("--azimuth", o->azimuth,
                               "default camera: degrees about the view-up (default 30; 0 with "
                               "--view)");
    auto* el = sub->add_option("--elevation", o->elevation,
                               "default camera: degrees up (default 20; 0 with --view)");
    sub->add_option("--zoom", o->zoom, "default camera: distance / zoom (default 1)");
    sub->add_option("--view", o->view,
                    "+x|-x|+y|-y|+z|-z: look along an axis (up +z; +y for +-z), framing what "
                    "the TF shows");
    sub->add_option("--frame", o->frame,
                    "visible | box: what the default camera frames (default: visible without "
                    "--tf, else SPEC 5's camera, which fits the box's bounding sphere)");
    sub->add_flag("--force", o->force,
                  "render even when --step gives over 1e9 samples or --size over 8192^2 rays");
    sub->add_option("--step", o->step,
                    "ray step, world units (default: half the smallest "
                    "full-resolution spacing)");
    sub->add_option("--unit-distance", o->unit,
                    "TF opacity unit distance, world units (default: smallest full-res spacing)");
    sub->add_option("--early-exit", o->earlyExit,
                    "stop a ray when accumulated alpha exceeds this (default 0.99; 1 disables)");
    sub->add_option("--background", o->background, "background r,g,b in [0,1] (default 1,1,1)");
    sub->add_option("--uniform-width", o->uniformWidth,
                    "model uniform: variance (mu -/+ sqrt(3) sigma, default) or minmax");
    sub->add_flag("--no-skip", o->noSkip, "disable empty-space skipping");
    sub->add_option("--realizations", o->realizations, "gmm-mc: realizations (default 200)");
    sub->add_option("--seed", o->seed, "gmm-mc: random seed (default 1)");
    auto* jit = sub->add_option("--jitter", o->jitter, "jitter ray starts with this seed");
    sub->add_option("--frames", o->frames,
                    "time N frames after one warm-up; print median/min ms and frames/s");
    addRawLayoutOptions(sub, o->raw);
    sub->add_option("--var", o->var, "array/variable name in the input");
    addEnsembleOptions(sub, o->ensemble);
    sub->callback([o, jit, ps, az, el] {
        run(*o, jit->count() > 0, ps->count() > 0, az->count() > 0, el->count() > 0);
    });
}

}  // namespace udvr::cmd
