#pragma once
// The options of a classification and of a frame (SPEC §4–5), each described once: name, type,
// default, accepted range and help. Every front end is generated from these tables — `udvr
// render`/`udvr probe` register their flags from them (cmd/option_flags.h), `udvr serve` reads
// its query keys through them, Python's keywords are their names with '_' for '-' — so an
// option shared by all of them is added here and nowhere else.
#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <variant>

#include "udvr/render/render.h"
#include "udvr/stats/model_volume.h"

namespace udvr {

/// The options as typed: text as given, numbers range-checked (setOption). Their defaults are
/// the SPEC's; a text left empty means "the default the SPEC describes" (camera, background).
struct RenderOptions {
    // classification (render and probe)
    std::string uniformWidth = "variance";  // "variance" (alias "std") or "minmax"
    // bivariate (render, probe, serve; SPEC §9): the file giving a 2D TF's y, and its array
    std::string second, secondVar;
    // frame (render)
    std::string size = "512x512";
    std::string view, frame;  // framed default camera (render/framing.h)
    std::string position, focal, up, background;
    double viewAngle = kDefaultViewAngleDeg, parallelScale = 0.0;
    double azimuth = kDefaultAzimuthDeg, elevation = kDefaultElevationDeg, zoom = kDefaultZoom;
    double step = 0.0, unit = 0.0, earlyExit = 0.99;  // world units; 0 = the defaults of SPEC §5
    bool noSkip = false, force = false;
    std::uint64_t realizations = 200, seed = 1, jitter = 0;
    // Whether the option was given (where its default differs from "absent").
    bool jitterGiven = false, parallelGiven = false, azimuthGiven = false, elevationGiven = false;
};

/// One option: its name (the CLI's flag without dashes and `udvr serve`'s query key; Python's
/// keyword with '_' for '-'), the field it sets — whose type is the option's (text, real, whole
/// number, or a flag) and whose value in a default-constructed RenderOptions is its default —
/// the range a number must lie in, and one line of help, where "{}" stands for the default
/// (optionHelp).
struct OptionSpec {
    using Field = std::variant<std::string RenderOptions::*, double RenderOptions::*,
                               std::uint64_t RenderOptions::*, bool RenderOptions::*>;
    const char* name;
    Field field;
    double lo = 0.0, hi = 0.0;  // real or whole: the accepted range [lo, hi]
    bool loOpen = false;        // real: lo itself is refused (the range is (lo, hi])
    bool remote = true;         // `udvr serve` takes it as a query key (--force is the CLI's alone)
    const char* help = "";
    bool RenderOptions::*given = nullptr;  // set true when the option is given
};

/// The classification options (render and probe): --uniform-width.
std::span<const OptionSpec> classificationOptionSpecs();
/// The frame options (render): size, camera, step, unit distance, early exit, background,
/// skipping, gmm-mc realizations and seed, jitter, --force.
std::span<const OptionSpec> frameOptionSpecs();
/// The bivariate options (render, probe, serve; not query keys): --second and --second-var.
std::span<const OptionSpec> bivariateOptionSpecs();
/// The option named `name` in the classification or frame table ('_' matches '-'), or null.
const OptionSpec* findOptionSpec(std::string_view name);

/// `spec`'s default (its field in RenderOptions{}) as the CLI would take it: "512x512", "30".
std::string optionDefaultText(const OptionSpec& spec);
/// `spec`'s help with "{}" replaced by optionDefaultText: what `--help` and Python print.
std::string optionHelp(const OptionSpec& spec);

/// Set `spec`'s field from `text` as typed: numbers must be finite, whole where the field is,
/// and in the spec's range; flags take 1/0/true/false. `label` names the option in the error
/// ("--step", or a query key).
void setOption(RenderOptions& options, const OptionSpec& spec, const std::string& text,
               const std::string& label);

/// Largest gmm-mc realization count without --force (each is a frame of its own).
inline constexpr std::uint64_t kMaxRealizationsWithoutForce = 10000;
/// More rays than this per frame ask for --force: 8192² floats are 1 GiB of image.
inline constexpr double kMaxPixelsWithoutForce = 8192.0 * 8192.0;
/// More samples than this per frame (every ray crossing the box's diagonal) from an explicit
/// --step ask for --force.
inline constexpr double kMaxSamplesWithoutForce = 1e9;

/// --uniform-width: "variance" (alias "std"; μ ± √3σ, the default) → false, "minmax" → true.
bool uniformWidthIsMinMax(const RenderOptions& options);

/// --second gives the y of a 2D TF (SPEC §9): fails when `secondGiven` without `tf2Given`.
/// `secondLabel` and `tf2Label` name the two as the front end spells them ("--second", "--tf2";
/// Python's "second", "a TransferFunction2D").
void requireTf2ForSecond(bool secondGiven, bool tf2Given, std::string_view secondLabel = "--second",
                         std::string_view tf2Label = "--tf2");
/// The bivariate options' checks (--second needs --tf2, --second-var needs --second).
void checkBivariateOptions(const RenderOptions& options, bool tf2Given);
/// The array to read from --second: --second-var, else `var` (the input's --var).
const std::string& secondFieldVar(const RenderOptions& options, const std::string& var);

/// The checks that need no data (size, --parallel-scale, --view, --frame, realizations);
/// returns the size.
std::array<int, 2> checkRenderOptions(const RenderOptions& options);

/// The frame's settings for `model`: size, camera (--position as given; else SPEC §5's default
/// camera unless --view or --frame was given, whatever the TF; else a camera framing
/// visibleBox(), or with --frame box the whole volume), step, unit distance, early exit,
/// background, skipping, uniform width, gmm-mc realizations and seed, jitter. `cameraNote` gets
/// what the framed camera frames (empty for the others).
RenderSettings renderSettingsFromOptions(const RenderOptions& options, const ModelVolume& model,
                                         const std::function<std::array<double, 6>()>& visibleBox,
                                         std::string& cameraNote);

}  // namespace udvr
