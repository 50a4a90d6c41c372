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

struct ClassifyOptions;  // classify/model_kernels.h

/// The options as typed: text as given, numbers range-checked (setOption). Each field starts at
/// its row's default (OptionSpec::defaultValue; the constructor sets them from the tables), the
/// one place a default is written; a text left empty means "the default the SPEC describes"
/// (camera, background).
struct RenderOptions {
    RenderOptions();  // every field at its row's default
    // classification (render and probe)
    std::string uniformWidth;  // "variance" (alias "std") or "minmax"
    // bivariate (render, probe, serve; SPEC §9): the file giving a 2D TF's y, and its array
    std::string second, secondVar;
    // frame (render)
    std::string size;
    std::string view, frame;  // framed default camera (render/framing.h)
    std::string position, focal, up, background;
    double viewAngle{}, parallelScale{}, azimuth{}, elevation{}, zoom{};  // degrees; world units
    double step{}, unit{}, earlyExit{};  // world units; 0 = the defaults of SPEC §5
    bool noSkip{}, force{};
    std::uint64_t realizations{}, seed{}, jitter{};
    // Whether the option was given (where its default differs from "absent"): --parallel-scale
    // makes the camera orthographic only when given (its default is Camera's, unused).
    bool jitterGiven = false, parallelGiven = false, azimuthGiven = false, elevationGiven = false;
};

/// One option: its name (the CLI's flag without dashes and `udvr serve`'s query key; Python's
/// keyword with '_' for '-'), the field it sets — whose type is the option's (text, real, whole
/// number, or a flag) — its default (of the field's type: text, real, whole or flag, checked at
/// compile time), the range a number must lie in, and one line of help, where "{}" stands for
/// the default (optionHelp).
struct OptionSpec {
    using Field = std::variant<std::string RenderOptions::*, double RenderOptions::*,
                               std::uint64_t RenderOptions::*, bool RenderOptions::*>;
    using Value = std::variant<const char*, double, std::uint64_t, bool>;  // Field's order
    const char* name;
    Field field;
    Value defaultValue;
    double lo = 0.0, hi = 0.0;  // real or whole: the accepted range [lo, hi]
    bool loOpen = false;        // real: lo itself is refused (the range is (lo, hi])
    bool remote = true;         // `udvr serve` takes it as a query key (--force is the CLI's alone)
    const char* help = "";
    bool RenderOptions::*given = nullptr;  // set true when the option is given
};

/// The classification options (render and probe): --uniform-width.
std::span<const OptionSpec> classificationOptionSpecs();
/// The frame options (render): size, camera, step, unit distance, early exit, background,
/// skipping, gmm-mc realizations and seed, jitter.
std::span<const OptionSpec> frameOptionSpecs();
/// The bivariate options (render, probe, serve; not query keys): --second and --second-var.
std::span<const OptionSpec> bivariateOptionSpecs();
/// --force (render, probe, serve; not a query key): go past the size caps below and the 2D TF's
/// widget-evaluation cap (Tf2ReadOptions::force).
std::span<const OptionSpec> forceOptionSpecs();
/// The option named `name` in the classification, frame or force table ('_' matches '-'), or
/// null.
const OptionSpec* findOptionSpec(std::string_view name);

/// `spec`'s default as the CLI would take it: "512x512", "30".
std::string optionDefaultText(const OptionSpec& spec);
/// `spec`'s help with "{}" replaced by optionDefaultText: what `--help` and Python print.
std::string optionHelp(const OptionSpec& spec);
/// The range a number option accepts as setOption's error states it: "(0, 1000]", "[1,
/// 2147483647]"; empty for text and flags.
std::string optionRangeText(const OptionSpec& spec);

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

/// The classification settings of `options` (--uniform-width), as render and probe take them.
ClassifyOptions classifyOptionsFrom(const RenderOptions& options);

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
