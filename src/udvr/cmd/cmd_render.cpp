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
#include "udvr/cmd/option_flags.h"
#include "udvr/cmd/parse_util.h"
#include "udvr/io/field_io.h"
#include "udvr/io/image.h"
#include "udvr/io/model_io.h"
#include "udvr/io/transfer_function_io.h"
#include "udvr/render/frame_estimate.h"
#include "udvr/render/framing.h"
#include "udvr/render/render.h"
#include "udvr/stats/model_volume.h"
#include "udvr/util/check.h"
#include "udvr/util/parallel.h"

namespace udvr::cmd {
namespace {

struct RenderOpts {
    std::vector<std::string> inputs;  // one model or field; an ensemble for --model members
    std::string model = "mean", out, floatOut;
    TfFlags tf;            // 1D TF: file or preset (default: a preset over the data)
    RenderOptions render;  // classification and frame options (render/render_options.h)
    int frames = 0;
    Tf2Flags tf2;        // 2D TF (SPEC §9)
    RawLayoutFlags raw;  // headerless .raw input
    std::string var;
    EnsembleFlags ensemble;  // --model members
};

/// "render: this frame will take about 390 s (a 64x64 probe took 6.1 s); shorter: …".
std::string estimateWarning(const RenderOpts& o, const RenderSettings& s, const FrameEstimate& e) {
    const double seconds = e.ms / 1000.0;
    // The side that brings the frame under ~10 s (time goes with the pixel count).
    const double shrink = std::sqrt(kLongFrameMs / e.ms);
    const int w = std::max(8, static_cast<int>(s.width * shrink));
    const int h = std::max(8, static_cast<int>(s.height * shrink));
    std::string cheaper;
    if (o.model == "gmm-mc")
        cheaper = ", fewer --realizations (time goes with them), or --model gmm-ordered";
    else if (o.model == "uniform" || o.model == "uniform-exact" || o.model == "gaussian" ||
             o.model == "gaussian-exact")
        cheaper = !o.tf2.file.empty()
                      ? ", a quantile model (quantile-range, quantile-mean: a polyline per "
                        "sample, not a 2D integral) or a 1D --tf"
                      : ", or uniform / gaussian (the fast forms)";
    char text[512];
    std::snprintf(
        text, sizeof text,
        "render: this frame will take about %.0f s (probes of it up to %dx%d took %.2f s); "
        "shorter: --size %dx%d (about 10 s)%s; progress is shown as it runs",
        seconds, e.width, e.height, e.probeMs / 1000.0, w, h, cheaper.c_str());
    return text;
}

/// The settings an image was made with, as PNG text chunks (issue 35): `udvr compare` refuses
/// two images whose TF, camera or size differ. 1D TFs as ParaView JSON; a 2D TF by its file and
/// the flags that shape it.
PngText renderSettingsText(const RenderOpts& o, ModelKind kind, const TransferFunction1D* tf,
                           const RenderSettings& s) {
    char text[512];
    PngText out;
    out.emplace_back("Software", "udvr render");
    out.emplace_back("udvr:model", std::string(modelName(kind)));
    std::string source;
    for (const std::string& in : o.inputs) source += (source.empty() ? "" : " ") + in;
    out.emplace_back("udvr:source", source);
    if (tf != nullptr) {
        out.emplace_back("udvr:tf",
                         transferFunctionToJson(*tf, o.tf.tf.empty() ? "udvr" : o.tf.tf));
        std::snprintf(text, sizeof text, "%.9g,%.9g", tf->colorX.front(), tf->colorX.back());
        out.emplace_back("udvr:tf-range", text);
    } else {
        out.emplace_back("udvr:tf", "tf2 " + o.tf2.file + " domain " + o.tf2.domain +
                                        " resolution " + o.tf2.resolution + " second " +
                                        o.render.second);
    }
    const Camera& c = s.camera;
    std::snprintf(text, sizeof text,
                  "position %.9g,%.9g,%.9g focal-point %.9g,%.9g,%.9g view-up %.9g,%.9g,%.9g %s "
                  "%.9g",
                  c.position[0], c.position[1], c.position[2], c.focalPoint[0], c.focalPoint[1],
                  c.focalPoint[2], c.viewUp[0], c.viewUp[1], c.viewUp[2],
                  c.parallel ? "parallel-scale" : "view-angle",
                  c.parallel ? c.parallelScale : c.viewAngleDeg);
    out.emplace_back("udvr:camera", text);
    out.emplace_back("udvr:size", std::to_string(s.width) + "x" + std::to_string(s.height));
    return out;
}

void run(const RenderOpts& o) {
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
    {
        std::vector<std::string> inputs = o.inputs;
        inputs.insert(inputs.end(), {o.render.second, o.tf.tf, o.tf2.file});
        requireOutputsNotInputs({{"-o", o.out}, {"--float", o.floatOut}}, inputs);
    }
    const ModelKind kind = parseModelKind(o.model);
    requireOneTf(o.tf.tf, o.tf2);
    const bool twoD = !o.tf2.file.empty();
    const bool members = readsMembers(kind);
    if (!members && o.inputs.size() != 1)
        UDVR_FAIL("render takes one model or field, got "
                  << o.inputs.size()
                  << " inputs (member files are an ensemble: --model members renders its members' "
                     "average classification, `udvr build` models it)");
    requireSecondForMembersTf2(o.render, members, twoD);
    const std::string& input = o.inputs.front();
    checkTfFlags(o.tf, twoD);
    checkRenderOptions(o.render);  // cheap flags are checked before the volume is read
    const bool tfGiven = twoD || !tfIsPreset(o.tf);
    // A TF file is read before the volume, so a bad one costs nothing; a preset needs the data.
    TfChoice tfChoice;
    if (!twoD && tfGiven) tfChoice.tf = readTransferFunctionFile(o.tf);
    const TransferFunction2D tf2 =
        twoD ? readTransferFunction2D(o.tf2.file, toTf2ReadOptions(o.tf2, o.render.force))
             : TransferFunction2D{};
    checkBivariateOptions(o.render, twoD);
    const ModelVolume model = members ? readMembersModel(o.inputs, o.var, o.raw, o.ensemble)
                                      : readModelOrField(input, o.var, o.raw);
    if (!twoD && !tfGiven) tfChoice = chooseTransferFunction(o.tf, model, "render");
    const TransferFunction1D& tf = tfChoice.tf;
    const bool bivariate = !o.render.second.empty();
    const ModelVolume second =
        bivariate ? readSecondInput(o.render, o.var, o.raw, o.ensemble, members) : ModelVolume{};

    bool anyVisible = true;
    std::array<double, 6> framedBox{};  // what the framed camera fits (when it is used)
    const auto visibleBox = [&] {
        framedBox =
            twoD ? visibleBounds(model, tf2, &anyVisible) : visibleBounds(model, tf, &anyVisible);
        return framedBox;
    };
    std::string cameraNote;
    const RenderSettings s = renderSettingsFromOptions(o.render, model, visibleBox, cameraNote);

    RenderStats stats;
    RenderCache cache;  // skipping tables built by the first frame, reused by the timed ones
    const auto frameWith = [&](const RenderSettings& at) {
        if (bivariate) return renderBivariate(model, second, kind, tf2, at, &stats, &cache);
        return twoD ? renderVolume(model, kind, tf2, at, &stats, &cache)
                    : renderVolume(model, kind, tf, at, &stats, &cache);
    };
    const auto frame = [&] { return frameWith(s); };
    const FrameEstimate estimate =
        estimateFrame(s, rendersRealizations(kind), [&](const RenderSettings& at) {
            frameWith(at);
            return stats.milliseconds;
        });
    if (estimate.ms > kLongFrameMs)
        std::fprintf(stderr, "%s\n", estimateWarning(o, s, estimate).c_str());
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
    writePng(o.out, image, renderSettingsText(o, kind, twoD ? nullptr : &tf, s));
    // What the TF shows, whatever the camera: the framed camera computed it already.
    if (cameraNote.empty()) visibleBox();
    const bool wholeBox = anyVisible && framedBox == model.bounds;
    if (!cameraNote.empty()) {
        if (!anyVisible) {
            const std::string visible = "the visible voxels";
            const auto at = cameraNote.find(visible);
            if (at != std::string::npos)
                cameraNote.replace(at, visible.size(), "the whole volume (nothing is visible)");
        }
        std::fprintf(stderr, "%s\n", cameraNote.c_str());
    }
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
    const auto& cam = s.camera;
    std::fprintf(stderr,
                 "render: camera pos %.6g %.6g %.6g  focal %.6g %.6g %.6g  up %.6g %.6g %.6g  %s "
                 "%.6g\n",
                 cam.position[0], cam.position[1], cam.position[2], cam.focalPoint[0],
                 cam.focalPoint[1], cam.focalPoint[2], cam.viewUp[0], cam.viewUp[1], cam.viewUp[2],
                 cam.parallel ? "parallel-scale" : "view-angle",
                 cam.parallel ? cam.parallelScale : cam.viewAngleDeg);

    std::fprintf(stderr,
                 "render: %s %dx%d in %.1f ms (estimated %.0f ms), %llu samples (%llu skipped) "
                 "-> %s\n",
                 std::string(modelName(kind)).c_str(), s.width, s.height, stats.milliseconds,
                 estimate.ms, static_cast<unsigned long long>(stats.samples),
                 static_cast<unsigned long long>(stats.skippedSamples), o.out.c_str());
}

}  // namespace

void addRenderCommand(CLI::App& app) {
    auto* sub = app.add_subcommand(
        "render", "ray-cast a field or a model volume with a transfer function (SPEC §5)");
    auto o = std::make_shared<RenderOpts>();
    sub->add_option(
           "input", o->inputs,
           "model .vti or .pvti from 'udvr build', or any scalar field; with --model members an "
           "ensemble (.nc with a member dimension, member files or a quoted glob)")
        ->required();
    sub->add_option("--model", o->model, "noise model (default mean): " + modelHelp());
    addTfOptions(sub, o->tf);
    addTf2Options(sub, o->tf2);
    addOptionFlags(sub, bivariateOptionSpecs(), o->render);
    sub->add_option("-o,--output", o->out, "output PNG")->required();
    sub->add_option("--float", o->floatOut, "also write float32 RGBA (.npy or .pfm)");
    addOptionFlags(sub, classificationOptionSpecs(), o->render);
    addOptionFlags(sub, frameOptionSpecs(), o->render);
    addOptionFlags(sub, forceOptionSpecs(), o->render);
    sub->add_option("--frames", o->frames,
                    "time N frames after one warm-up; print median/min ms and frames/s");
    addRawLayoutOptions(sub, o->raw);
    sub->add_option("--var", o->var, "array/variable name in the input");
    addEnsembleOptions(sub, o->ensemble);
    sub->callback([o] {
        o->inputs = withOneMatchResolved(o->inputs);  // a quoted glob of one file is that file
        run(*o);
    });
}

}  // namespace udvr::cmd
