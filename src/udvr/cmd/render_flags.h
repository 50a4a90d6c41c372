#pragma once
// The camera and ray flags of `udvr render` (SPEC §5) as typed, and the RenderSettings they
// give: shared by `udvr render` and `udvr serve`, whose /api/render takes the same names, so a
// page's image and the CLI's are one computation.
#include <CLI/CLI.hpp>
#include <array>
#include <cstdint>
#include <functional>
#include <string>

#include "udvr/render/render.h"
#include "udvr/stats/model_volume.h"

namespace udvr::cmd {

/// Flags as typed (names as the CLI spells them, without the dashes).
struct RenderFlags {
    std::string size = "512x512";
    std::string view, frame;  // framed default camera (render/framing.h)
    std::string position, focal, up, background, uniformWidth = "variance";
    double viewAngle = 30.0, parallelScale = 0.0, azimuth = 30.0, elevation = 20.0, zoom = 1.0;
    double step = 0.0, unit = 0.0, earlyExit = 0.99;  // world units; 0 = the defaults of SPEC §5
    bool noSkip = false, force = false;
    int realizations = 200;
    std::uint64_t seed = 1, jitter = 0;
    // Whether the flag was given (its default differs from "absent").
    bool jitterGiven = false, parallelGiven = false, azimuthGiven = false, elevationGiven = false;
};

/// The CLI11 options whose presence matters; markGiven copies their counts into the flags.
struct RenderFlagOptions {
    CLI::Option *jitter = nullptr, *parallel = nullptr, *azimuth = nullptr, *elevation = nullptr;
    void markGiven(RenderFlags& flags) const;
};
/// Register --size, the camera flags, --view/--frame, --force, --step, --unit-distance,
/// --early-exit, --background, --uniform-width, --no-skip, --realizations, --seed, --jitter.
RenderFlagOptions addRenderFlagOptions(CLI::App* sub, RenderFlags& flags);

/// More rays than this per frame ask for --force: 8192² floats are 1 GiB of image.
inline constexpr double kMaxPixelsWithoutForce = 8192.0 * 8192.0;
/// More samples than this per frame (every ray crossing the box's diagonal) from an explicit
/// --step ask for --force.
inline constexpr double kMaxSamplesWithoutForce = 1e9;

/// The checks that need no data (size, --parallel-scale, --view, --frame); returns the size.
std::array<int, 2> checkRenderFlags(const RenderFlags& flags);

/// The frame's settings for `model`: size, camera (--position as given; else SPEC §5's default
/// camera when a TF was given and neither --view nor --frame was; else a camera framing
/// visibleBox(), or with --frame box the whole volume), step, unit distance, early exit,
/// background, skipping, uniform width, gmm-mc realizations and seed, jitter. `cameraNote` gets
/// what the framed camera frames (empty for the others).
RenderSettings renderSettingsFromFlags(const RenderFlags& flags, const ModelVolume& model,
                                       bool tfGiven,
                                       const std::function<std::array<double, 6>()>& visibleBox,
                                       std::string& cameraNote);

}  // namespace udvr::cmd
