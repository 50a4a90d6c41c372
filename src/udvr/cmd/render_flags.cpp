#include "udvr/cmd/render_flags.h"

#include <cmath>
#include <cstdio>

#include "udvr/cmd/parse_util.h"
#include "udvr/render/framing.h"
#include "udvr/util/check.h"

namespace udvr::cmd {
namespace {

// The camera: --position (SPEC §5) as given; else SPEC §5's default camera when a TF was given
// and neither --view nor --frame was; else a camera framing the visible part of the volume
// (or, --frame box, all of it) from --view or the z-up front view.
Camera cameraFromFlags(const RenderFlags& o, const ModelVolume& m, bool tfGiven,
                       const std::function<std::array<double, 6>()>& visibleBox, double aspect,
                       std::string& note) {
    const auto& b = m.bounds;
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
            const double az = o.azimuthGiven ? o.azimuth : (o.view.empty() ? 30.0 : 0.0);
            const double el = o.elevationGiven ? o.elevation : (o.view.empty() ? 20.0 : 0.0);
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

}  // namespace

void RenderFlagOptions::markGiven(RenderFlags& flags) const {
    flags.jitterGiven = jitter->count() > 0;
    flags.parallelGiven = parallel->count() > 0;
    flags.azimuthGiven = azimuth->count() > 0;
    flags.elevationGiven = elevation->count() > 0;
}

RenderFlagOptions addRenderFlagOptions(CLI::App* sub, RenderFlags& o) {
    RenderFlagOptions opts;
    sub->add_option("--size", o.size, "image size WxH (default 512x512)");
    sub->add_option("--position", o.position, "camera position x,y,z (world units)");
    sub->add_option("--focal-point", o.focal, "focal point x,y,z (default: box centre)");
    sub->add_option("--view-up", o.up, "view-up x,y,z (default 0,1,0)");
    sub->add_option("--view-angle", o.viewAngle, "vertical view angle, degrees (default 30)");
    opts.parallel = sub->add_option("--parallel-scale", o.parallelScale,
                                    "orthographic: half the view height, world units");
    opts.azimuth = sub->add_option("--azimuth", o.azimuth,
                                   "default camera: degrees about the view-up (default 30; 0 with "
                                   "--view)");
    opts.elevation = sub->add_option("--elevation", o.elevation,
                                     "default camera: degrees up (default 20; 0 with --view)");
    sub->add_option("--zoom", o.zoom, "default camera: distance / zoom (default 1)");
    sub->add_option("--view", o.view,
                    "+x|-x|+y|-y|+z|-z: look along an axis (up +z; +y for +-z), framing what "
                    "the TF shows");
    sub->add_option("--frame", o.frame,
                    "visible | box: what the default camera frames (default: visible without "
                    "--tf, else SPEC 5's camera, which fits the box's bounding sphere)");
    sub->add_flag("--force", o.force,
                  "render even when --step gives over 1e9 samples or --size over 8192^2 rays");
    sub->add_option("--step", o.step,
                    "ray step, world units (default: half the smallest "
                    "full-resolution spacing)");
    sub->add_option("--unit-distance", o.unit,
                    "TF opacity unit distance, world units (default: smallest full-res spacing)");
    sub->add_option("--early-exit", o.earlyExit,
                    "stop a ray when accumulated alpha exceeds this (default 0.99; 1 disables)");
    sub->add_option("--background", o.background, "background r,g,b in [0,1] (default 1,1,1)");
    sub->add_option("--uniform-width", o.uniformWidth,
                    "model uniform: variance (mu -/+ sqrt(3) sigma, default) or minmax");
    sub->add_flag("--no-skip", o.noSkip, "disable empty-space skipping");
    sub->add_option("--realizations", o.realizations, "gmm-mc: realizations (default 200)");
    sub->add_option("--seed", o.seed, "gmm-mc: random seed (default 1)");
    opts.jitter = sub->add_option("--jitter", o.jitter, "jitter ray starts with this seed");
    return opts;
}

std::array<int, 2> checkRenderFlags(const RenderFlags& o) {
    if (o.parallelGiven && !(o.parallelScale > 0.0))
        UDVR_FAIL("--parallel-scale must be > 0, got " << o.parallelScale);
    const auto size = parseSize(o.size, "--size");
    if (static_cast<double>(size[0]) * size[1] > kMaxPixelsWithoutForce && !o.force)
        UDVR_FAIL("--size " << o.size << " is over " << kMaxPixelsWithoutForce / 1e6
                            << " million rays per frame; add --force to render anyway");
    if (!o.frame.empty() && o.frame != "box" && o.frame != "visible")
        UDVR_FAIL("--frame must be 'visible' or 'box', got '" << o.frame << "'");
    if (!o.view.empty()) parseViewDirection(o.view);
    return size;
}

RenderSettings renderSettingsFromFlags(const RenderFlags& o, const ModelVolume& model, bool tfGiven,
                                       const std::function<std::array<double, 6>()>& visibleBox,
                                       std::string& cameraNote) {
    const auto size = checkRenderFlags(o);
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
    s.camera = cameraFromFlags(o, model, tfGiven, visibleBox,
                               static_cast<double>(s.width) / s.height, cameraNote);
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
    if (o.jitterGiven) s.jitterSeed = o.jitter;
    return s;
}

}  // namespace udvr::cmd
