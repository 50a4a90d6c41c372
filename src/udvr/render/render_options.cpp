#include "udvr/render/render_options.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <sstream>
#include <type_traits>

#include "udvr/classify/model_kernels.h"
#include "udvr/render/framing.h"
#include "udvr/util/check.h"
#include "udvr/util/text_parse.h"

namespace udvr {
namespace {

using O = RenderOptions;
constexpr double kHuge = 1e12;  // world units: far beyond any volume's extent
constexpr double kMaxWhole = static_cast<double>(std::numeric_limits<std::uint64_t>::max());

// One row per option: name, field and default; the range of a number; the help, where "{}"
// stands for the default (optionHelp).
// clang-format off
constexpr OptionSpec kClassificationOptions[] = {
    {.name = "uniform-width", .field = &O::uniformWidth, .defaultValue = "variance",
     .help = "model uniform: variance (mu -/+ sqrt(3) sigma; alias std) or minmax (default {})"},
};

constexpr OptionSpec kFrameOptions[] = {
    {.name = "size", .field = &O::size, .defaultValue = "512x512",
     .help = "image size WxH (default {})"},
    {.name = "position", .field = &O::position, .defaultValue = "",
     .help = "camera position x,y,z (world units)"},
    {.name = "focal-point", .field = &O::focal, .defaultValue = "",
     .help = "focal point x,y,z (default: box centre)"},
    {.name = "view-up", .field = &O::up, .defaultValue = "",
     .help = "view-up x,y,z (default 0,1,0)"},
    {.name = "view-angle", .field = &O::viewAngle, .defaultValue = kDefaultViewAngleDeg,
     .lo = 0.0, .hi = 179.9, .loOpen = true, .help = "vertical view angle, degrees (default {})"},
    {.name = "parallel-scale", .field = &O::parallelScale, .defaultValue = Camera{}.parallelScale,
     .lo = 0.0, .hi = kHuge, .loOpen = true,
     .help = "orthographic: half the view height, world units", .given = &O::parallelGiven},
    {.name = "azimuth", .field = &O::azimuth, .defaultValue = kDefaultAzimuthDeg,
     .lo = -3600.0, .hi = 3600.0,
     .help = "default camera: degrees about the view-up (default {}; 0 with --view)",
     .given = &O::azimuthGiven},
    {.name = "elevation", .field = &O::elevation, .defaultValue = kDefaultElevationDeg,
     .lo = -90.0, .hi = 90.0, .help = "default camera: degrees up (default {}; 0 with --view)",
     .given = &O::elevationGiven},
    {.name = "zoom", .field = &O::zoom, .defaultValue = kDefaultZoom,
     .lo = 0.0, .hi = 1000.0, .loOpen = true,
     .help = "default camera: distance / zoom (default {})"},
    {.name = "view", .field = &O::view, .defaultValue = "",
     .help = "+x|-x|+y|-y|+z|-z: look along an axis (up +z; +y for +-z), framing what the TF "
             "shows"},
    {.name = "frame", .field = &O::frame, .defaultValue = "",
     .help = "visible | box: frame the voxels the TF shows, or the whole box, z up, from the "
             "front (default: SPEC 5's camera, which fits the box's bounding sphere, whatever "
             "the TF)"},
    {.name = "step", .field = &O::step, .defaultValue = 0.0, .lo = 0.0, .hi = kHuge,
     .help = "ray step, world units (default {}: half the smallest full-resolution spacing)"},
    {.name = "unit-distance", .field = &O::unit, .defaultValue = 0.0, .lo = 0.0, .hi = kHuge,
     .help = "TF opacity unit distance, world units (default {}: smallest full-res spacing)"},
    {.name = "early-exit", .field = &O::earlyExit, .defaultValue = 0.99,
     .lo = 0.0, .hi = 1.0, .loOpen = true,
     .help = "stop a ray when accumulated alpha exceeds this (default {}; 1 disables)"},
    {.name = "background", .field = &O::background, .defaultValue = "",
     .help = "background r,g,b in [0,1] (default 1,1,1)"},
    {.name = "no-skip", .field = &O::noSkip, .defaultValue = false,
     .help = "disable empty-space skipping"},
    {.name = "realizations", .field = &O::realizations, .defaultValue = std::uint64_t{200},
     .lo = 1.0, .hi = 2147483647.0,
     .help = "gmm-mc: realizations (default {}; over 10000 needs --force)"},
    {.name = "seed", .field = &O::seed, .defaultValue = std::uint64_t{1},
     .lo = 0.0, .hi = kMaxWhole, .help = "gmm-mc: random seed (default {})"},
    {.name = "jitter", .field = &O::jitter, .defaultValue = std::uint64_t{0},
     .lo = 0.0, .hi = kMaxWhole, .help = "jitter ray starts with this seed",
     .given = &O::jitterGiven},
};

constexpr OptionSpec kForceOptions[] = {
    {.name = "force", .field = &O::force, .defaultValue = false, .remote = false,
     .help = "go past a size cap: --step over 1e9 samples, --size over 8192^2 rays, "
             "--realizations over 10000 (render), a --tf2 widget file over 1e8 widget "
             "evaluations (render, probe, serve)"},
};

constexpr OptionSpec kBivariateOptions[] = {
    {.name = "second", .field = &O::second, .defaultValue = "", .remote = false,
     .help = "bivariate fields: the model or field giving the TF2's y (same grid; x comes from "
             "the input; needs --tf2; SPEC 9)"},
    {.name = "second-var", .field = &O::secondVar, .defaultValue = "", .remote = false,
     .help = "array/variable name in --second (default: --var)"},
};
// clang-format on

// A whole-number option's largest value (kMaxWhole: the type's).
std::uint64_t wholeHi(const OptionSpec& spec) {
    return spec.hi >= kMaxWhole ? std::numeric_limits<std::uint64_t>::max()
                                : static_cast<std::uint64_t>(spec.hi);
}

bool sameName(std::string_view a, std::string_view b) {
    if (a.size() != b.size()) return false;
    for (std::size_t i = 0; i < a.size(); ++i) {
        const char x = a[i] == '_' ? '-' : a[i], y = b[i] == '_' ? '-' : b[i];
        if (x != y) return false;
    }
    return true;
}

// The camera: --position (SPEC §5) as given; else SPEC §5's default camera unless --view or
// --frame was given — whatever the TF and wherever it came from, so a model and its ground
// truth rendered with defaults are seen alike (issue 35); else a camera framing the visible part
// of the volume (or, --frame box, all of it) from --view or the z-up front view.
Camera cameraFromOptions(const RenderOptions& o, const ModelVolume& m,
                         const std::function<std::array<double, 6>()>& visibleBox, double aspect,
                         std::string& note) {
    const auto& b = m.bounds;
    if (!o.position.empty() && (!o.view.empty() || !o.frame.empty()))
        UDVR_FAIL("--view and --frame choose the default camera; they do not go with --position");
    if (o.position.empty()) {
        if (!o.focal.empty() || !o.up.empty())
            UDVR_FAIL("--focal-point/--view-up need --position (or use --azimuth/--elevation)");
        const bool framed = !o.view.empty() || !o.frame.empty();
        Camera c;
        if (!framed) {
            c = defaultCamera(b, o.azimuth, o.elevation, o.zoom, o.viewAngle);
        } else {
            const auto box = o.frame == "box" ? b : visibleBox();
            // The front view turned to SPEC §5's three-quarter view unless told otherwise; an
            // axis view straight along its axis (framing.h).
            c = framedCamera(box, o.view, o.azimuthGiven ? std::optional(o.azimuth) : std::nullopt,
                             o.elevationGiven ? std::optional(o.elevation) : std::nullopt, o.zoom,
                             o.viewAngle, aspect);
            char text[256];
            std::snprintf(text, sizeof text,
                          "render: camera frames %s [%.6g, %.6g] x [%.6g, %.6g] x [%.6g, %.6g] "
                          "(--frame box: the whole volume; --position: your own)",
                          o.frame == "box" ? "the volume" : "the visible voxels", box[0], box[1],
                          box[2], box[3], box[4], box[5]);
            note = text;
        }
        if (o.parallelGiven) {
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
    c.viewUp = o.up.empty() ? Camera{}.viewUp : parseVec3(o.up, "--view-up");
    c.viewAngleDeg = o.viewAngle;
    if (o.parallelGiven) {
        c.parallel = true;
        c.parallelScale = o.parallelScale;
    }
    return c;
}

// Every row's default has its field's type, a text default is given (even if empty), and a
// number's default lies in the row's own range (an option whose default means "not given"
// says so by its `given` field, not by a value outside the range).
consteval bool defaultsMatchFields(std::span<const OptionSpec> table) {
    for (const OptionSpec& s : table) {
        if (s.field.index() != s.defaultValue.index()) return false;
        if (const auto* text = std::get_if<const char*>(&s.defaultValue); text && !*text)
            return false;
        double v = 0.0;
        if (const auto* real = std::get_if<double>(&s.defaultValue))
            v = *real;
        else if (const auto* whole = std::get_if<std::uint64_t>(&s.defaultValue))
            v = static_cast<double>(*whole);
        else
            continue;
        if (v < s.lo || v > s.hi || (s.loOpen && v == s.lo)) return false;
    }
    return true;
}
static_assert(defaultsMatchFields(kClassificationOptions) && defaultsMatchFields(kFrameOptions) &&
              defaultsMatchFields(kBivariateOptions) && defaultsMatchFields(kForceOptions));

}  // namespace

std::span<const OptionSpec> classificationOptionSpecs() { return kClassificationOptions; }
std::span<const OptionSpec> frameOptionSpecs() { return kFrameOptions; }
std::span<const OptionSpec> bivariateOptionSpecs() { return kBivariateOptions; }
std::span<const OptionSpec> forceOptionSpecs() { return kForceOptions; }

RenderOptions::RenderOptions() {
    for (auto table : {classificationOptionSpecs(), frameOptionSpecs(), bivariateOptionSpecs(),
                       forceOptionSpecs()})
        for (const OptionSpec& spec : table)
            std::visit(
                [&](auto field) {
                    using T = std::remove_reference_t<decltype(this->*field)>;
                    if constexpr (std::is_same_v<T, std::string>)
                        this->*field = std::get<const char*>(spec.defaultValue);
                    else
                        this->*field = std::get<T>(spec.defaultValue);
                },
                spec.field);
}

const OptionSpec* findOptionSpec(std::string_view name) {
    for (auto table : {classificationOptionSpecs(), frameOptionSpecs(), forceOptionSpecs()})
        for (const OptionSpec& s : table)
            if (sameName(s.name, name)) return &s;
    return nullptr;
}

std::string optionDefaultText(const OptionSpec& spec) {
    return std::visit(
        [](auto v) -> std::string {
            using T = decltype(v);
            if constexpr (std::is_same_v<T, const char*>) {
                return v;
            } else if constexpr (std::is_same_v<T, bool>) {
                return v ? "1" : "0";
            } else if constexpr (std::is_same_v<T, double>) {
                char text[32];
                std::snprintf(text, sizeof text, "%.10g", v);
                return text;
            } else {
                return std::to_string(v);
            }
        },
        spec.defaultValue);
}

std::string optionHelp(const OptionSpec& spec) {
    std::string help = spec.help;
    if (const auto at = help.find("{}"); at != std::string::npos)
        help.replace(at, 2, optionDefaultText(spec));
    return help;
}

std::string optionRangeText(const OptionSpec& spec) {
    std::ostringstream text;
    if (std::holds_alternative<double RenderOptions::*>(spec.field))
        text << (spec.loOpen ? "(" : "[") << spec.lo << ", " << spec.hi << "]";
    else if (std::holds_alternative<std::uint64_t RenderOptions::*>(spec.field))
        text << "[" << static_cast<std::uint64_t>(spec.lo) << ", " << wholeHi(spec) << "]";
    return text.str();
}

void setOption(RenderOptions& o, const OptionSpec& spec, const std::string& text,
               const std::string& label) {
    std::visit(
        [&](auto field) {
            using T = std::remove_reference_t<decltype(o.*field)>;
            if constexpr (std::is_same_v<T, std::string>) {
                o.*field = text;
            } else if constexpr (std::is_same_v<T, bool>) {
                o.*field = parseBool(text, label);
            } else if constexpr (std::is_same_v<T, double>) {
                const double v = parseReal(text, label);
                if (v < spec.lo || v > spec.hi || (spec.loOpen && v == spec.lo))
                    UDVR_FAIL(label << " must lie in " << optionRangeText(spec) << ", got " << v);
                o.*field = v;
            } else {
                static_assert(std::is_same_v<T, std::uint64_t>);
                o.*field =
                    parseWhole(text, label, static_cast<std::uint64_t>(spec.lo), wholeHi(spec));
            }
        },
        spec.field);
    if (spec.given) o.*spec.given = true;
}

ClassifyOptions classifyOptionsFrom(const RenderOptions& o) {
    ClassifyOptions c;
    c.uniformMinMax = uniformWidthIsMinMax(o);
    return c;
}

bool uniformWidthIsMinMax(const RenderOptions& o) {
    if (o.uniformWidth == "variance" || o.uniformWidth == "std") return false;
    if (o.uniformWidth == "minmax") return true;
    UDVR_FAIL("--uniform-width must be 'variance' (or 'std') or 'minmax', got '"
              << clipForMessage(o.uniformWidth) << "'");
}

void requireTf2ForSecond(bool secondGiven, bool tf2Given, std::string_view secondLabel,
                         std::string_view tf2Label) {
    if (secondGiven && !tf2Given)
        UDVR_FAIL(secondLabel << " gives the y of a 2D transfer function: it needs " << tf2Label);
}

void checkBivariateOptions(const RenderOptions& o, bool tf2Given) {
    requireTf2ForSecond(!o.second.empty(), tf2Given);
    if (!o.secondVar.empty() && o.second.empty())
        UDVR_FAIL("--second-var names the array in --second; it needs --second");
}

const std::string& secondFieldVar(const RenderOptions& o, const std::string& var) {
    return o.secondVar.empty() ? var : o.secondVar;
}

std::array<int, 2> checkRenderOptions(const RenderOptions& o) {
    if (o.parallelGiven && !(o.parallelScale > 0.0))
        UDVR_FAIL("--parallel-scale must be > 0, got " << o.parallelScale);
    const auto size = parseSize(o.size, "--size");
    if (static_cast<double>(size[0]) * size[1] > kMaxPixelsWithoutForce && !o.force)
        UDVR_FAIL("--size " << o.size << " is over " << kMaxPixelsWithoutForce / 1e6
                            << " million rays per frame; add --force to render anyway");
    if (o.realizations < 1) UDVR_FAIL("--realizations must be at least 1, got " << o.realizations);
    if (o.realizations > kMaxRealizationsWithoutForce && !o.force)
        UDVR_FAIL("--realizations " << o.realizations << " is over " << kMaxRealizationsWithoutForce
                                    << " frames of gmm-mc; add --force to render anyway");
    if (!o.frame.empty() && o.frame != "box" && o.frame != "visible")
        UDVR_FAIL("--frame must be 'visible' or 'box', got '" << clipForMessage(o.frame) << "'");
    if (!o.view.empty()) parseViewDirection(o.view);
    uniformWidthIsMinMax(o);
    return size;
}

RenderSettings renderSettingsFromOptions(const RenderOptions& o, const ModelVolume& model,
                                         const std::function<std::array<double, 6>()>& visibleBox,
                                         std::string& cameraNote) {
    const auto size = checkRenderOptions(o);
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
    s.camera = cameraFromOptions(o, model, visibleBox, static_cast<double>(s.width) / s.height,
                                 cameraNote);
    s.step = o.step;
    s.unitDistance = o.unit;
    s.earlyExit = o.earlyExit;
    if (!o.background.empty()) {
        const auto bg = parseVec3(o.background, "--background");
        for (int c = 0; c < 3; ++c) s.background[c] = static_cast<float>(bg[c]);
    }
    s.skipEmpty = !o.noSkip;
    s.uniformMinMax = uniformWidthIsMinMax(o);
    s.realizations = static_cast<int>(o.realizations);
    s.seed = o.seed;
    if (o.jitterGiven) s.jitterSeed = o.jitter;
    return s;
}

}  // namespace udvr
