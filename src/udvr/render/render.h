#pragma once
// The CPU ray caster (SPEC §5): VTK-style camera, fixed step, opacity correction,
// premultiplied front-to-back compositing, early termination, empty-space skipping.
#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>

#include "udvr/classify/model_kind.h"
#include "udvr/classify/transfer_function.h"
#include "udvr/classify/transfer_function_2d.h"
#include "udvr/render/image_rgba.h"
#include "udvr/stats/model_view.h"

namespace udvr {

/// A VTK-style camera in world units.
/// SPEC §5's default camera (bench/peer/vtk_render.py): VTK's Azimuth and Elevation (degrees),
/// the zoom (distance / zoom) and the vertical view angle (degrees). `udvr render`'s option
/// defaults and help, the framed camera's three-quarter turn, serve's page and Python's Camera
/// all read these.
inline constexpr double kDefaultAzimuthDeg = 30.0;
inline constexpr double kDefaultElevationDeg = 20.0;
inline constexpr double kDefaultZoom = 1.0;
inline constexpr double kDefaultViewAngleDeg = 30.0;

struct Camera {
    std::array<double, 3> position{0, 0, 1};
    std::array<double, 3> focalPoint{0, 0, 0};
    std::array<double, 3> viewUp{0, 1, 0};
    double viewAngleDeg = kDefaultViewAngleDeg;  // vertical field of view (perspective)
    bool parallel = false;                       // orthographic when true
    double parallelScale = 1.0;  // half the viewport height in world units (orthographic)
};

/// The default camera of SPEC §5 / bench/peer/vtk_render.py: focal point at the box centre,
/// on +z looking −z with up +y at the distance where the bounding sphere fits the vertical view
/// angle, moved closer by `zoom` (distance / zoom), then VTK's Azimuth(about +y) and Elevation.
Camera defaultCamera(const std::array<double, 6>& bounds, double azimuthDeg = kDefaultAzimuthDeg,
                     double elevationDeg = kDefaultElevationDeg, double zoom = kDefaultZoom,
                     double viewAngleDeg = kDefaultViewAngleDeg);

/// A piece of a volume split across processes (the ParaView plugin under MPI, where each rank
/// renders its own piece and ParaView composites the pieces in visibility order). The rays still
/// place their samples along the whole volume's box (the model's `bounds`) as SPEC §5 says, but
/// only the samples inside `box` — from where a ray enters it up to, not including, where it
/// leaves — are composited, so pieces that tile the volume take every sample exactly once.
/// `offset` is the piece's first grid point in the whole grid and `wholeDims` the whole grid's
/// points: gmm-mc draws each voxel as the whole model would (its key is the whole grid's index).
struct RenderPiece {
    std::array<double, 6> box{};  // xmin,xmax,ymin,ymax,zmin,zmax, world units
    std::array<int, 3> offset{0, 0, 0};
    std::array<int, 3> wholeDims{0, 0, 0};
};

struct RenderSettings {
    int width = 512, height = 512;
    Camera camera;
    double step = 0.0;          // world units; 0 = half the full-res grid's smallest spacing
    double unitDistance = 0.0;  // TF opacity unit, world units; 0 = full-res smallest spacing
    double earlyExit = 0.99;    // stop when accumulated α exceeds this; 1.0 disables
    std::array<float, 3> background{1.f, 1.f, 1.f};
    bool skipEmpty = true;                    // empty-space skipping from per-brick support bounds
    int realizations = 200;                   // gmm-mc: realizations averaged in screen space
    std::uint64_t seed = 1;                   // gmm-mc realization seed
    std::optional<std::uint64_t> jitterSeed;  // per-ray start jitter in [0, Δ) when set
    bool uniformMinMax = false;        // model `uniform`: U[min, max] (`--uniform-width minmax`)
    std::optional<RenderPiece> piece;  // composite only this piece's samples (see RenderPiece)
    /// When set and it turns true, the frame stops between tiles (and gmm-mc realizations) and
    /// the render throws RenderCancelled (`udvr serve`: a newer request supersedes this one).
    const std::atomic<bool>* cancel = nullptr;
};

/// Thrown by a render whose RenderSettings::cancel turned true; no image comes back.
class RenderCancelled : public std::runtime_error {
  public:
    RenderCancelled() : std::runtime_error("render cancelled") {}
};

struct RenderStats {
    double milliseconds = 0.0;  // wall time of the frame (all realizations for gmm-mc)
    std::uint64_t samples = 0;  // classified samples
    std::uint64_t skippedSamples = 0;
};

/// Tables kept between frames of one model, kind and TF: the empty-space-skipping tables,
/// built on the first frame (as VTK's mapper builds its min-max volume) and reused while only
/// the camera, size or step change, and (2D TFs) the grid gradients of the model's arrays.
/// Rebuilt when the model's arrays, the kind or the TF's non-zero-opacity ranges differ; a
/// model edited in place (same arrays, new values) needs clear().
class RenderCache {
  public:
    RenderCache();
    ~RenderCache();
    RenderCache(const RenderCache&) = delete;
    RenderCache& operator=(const RenderCache&) = delete;
    /// Forget the cached tables.
    void clear();
    struct Impl;  // defined in render.cpp
    Impl& impl() { return *impl_; }

  private:
    std::unique_ptr<Impl> impl_;
};

/// Render one frame of `model` with noise model `kind`. The image holds straight (not
/// premultiplied) RGB composited over the background, alpha = accumulated opacity. Pass a
/// RenderCache to reuse the skipping tables across frames (optional; same image either way).
ImageRgba renderVolume(const ModelView& model, ModelKind kind, const TransferFunction1D& tf,
                       const RenderSettings& settings, RenderStats* stats = nullptr,
                       RenderCache* cache = nullptr);

/// Render with a 2D transfer function (SPEC §9): x the value, y the gradient magnitude G along
/// the mean gradient. Models: those with a 2D kernel (classify/model_families.h). Skipping uses
/// the x ranges where the TF2 has α > 0 for some y. A RenderCache keeps the skipping tables and
/// the model's grid gradients between frames.
ImageRgba renderVolume(const ModelView& model, ModelKind kind, const TransferFunction2D& tf,
                       const RenderSettings& settings, RenderStats* stats = nullptr,
                       RenderCache* cache = nullptr);

/// Render bivariate fields with a 2D transfer function (SPEC §9 `--second`, fuzzy fiber
/// surfaces): x from `first`, y from `second` (same grid), the fields independent, both under
/// model `kind`. Skipping uses the first field's supports and the x ranges where the TF2 has
/// α > 0.
ImageRgba renderBivariate(const ModelView& first, const ModelView& second, ModelKind kind,
                          const TransferFunction2D& tf, const RenderSettings& settings,
                          RenderStats* stats = nullptr, RenderCache* cache = nullptr);

/// Picking (`udvr serve`'s click probe): a sample is visible when its E[α] (the exact double
/// body) is at least this fraction of the largest E[α] on its ray, and at least kPickMinOpacity.
inline constexpr double kPickOpacityFraction = 0.01;
inline constexpr double kPickMinOpacity = 1e-4;  // opacity per unit distance

/// The first visible sample on the ray through pixel (px, py) of the frame `settings` describe
/// (SPEC §5 sample positions t_entry + (s + ½)Δ; jitter ignored), as an index-space point clamped
/// into the grid; nullopt when the ray misses the box or meets no visible sample. gmm-mc has no
/// per-sample kernel: it picks with gmm-ordered's expectation of the same mixtures.
std::optional<std::array<double, 3>> firstVisibleSample(const ModelView& model, ModelKind kind,
                                                        const TransferFunction1D& tf,
                                                        const RenderSettings& settings, int px,
                                                        int py);
/// firstVisibleSample with a 2D TF (value × gradient magnitude, SPEC §9).
std::optional<std::array<double, 3>> firstVisibleSample(const ModelView& model, ModelKind kind,
                                                        const TransferFunction2D& tf,
                                                        const RenderSettings& settings, int px,
                                                        int py);
/// firstVisibleSample for bivariate fields with a 2D TF (SPEC §9 `--second`).
std::optional<std::array<double, 3>> firstVisibleSampleBivariate(
    const ModelView& first, const ModelView& second, ModelKind kind, const TransferFunction2D& tf,
    const RenderSettings& settings, int px, int py);

}  // namespace udvr
