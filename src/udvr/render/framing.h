#pragma once
// Cameras that frame what is visible (`udvr render` without a camera of its own): the bounding
// box of the voxels a TF makes visible, axis views as ParaView's "Set view direction to ±X…",
// and the distance at which a box fills the image.
#include <array>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "udvr/render/render.h"

namespace udvr {

/// A view: the direction the camera looks along and its view-up (unit, orthogonal).
struct ViewDirection {
    std::array<double, 3> look{0, 0, -1};
    std::array<double, 3> up{0, 1, 0};
};

/// "+x" … "-z" as ParaView's axis views: look along that axis; up +z for ±x and ±y, +y for ±z.
/// Throws UdvrError naming the accepted values otherwise.
ViewDirection parseViewDirection(const std::string& text);

/// The view of the framed default camera: z up, looking along +y (from the −y side, the front
/// of a CT in LPS or RAS order); callers turn it by --azimuth and --elevation.
inline constexpr ViewDirection kZUpFrontView{{0, 1, 0}, {0, 0, 1}};

/// A perspective camera looking along `view` turned by VTK's Azimuth (about the view-up) and
/// Elevation, focal point at the centre of `box`, at the distance where every corner of the box
/// lies inside the image with a 5 % margin (for the image's aspect = width / height), then
/// moved closer by `zoom` (distance / zoom).
Camera framedCamera(const std::array<double, 6>& box, const ViewDirection& view, double azimuthDeg,
                    double elevationDeg, double zoom, double viewAngleDeg, double aspect);

/// `udvr render --view/--frame`'s camera: `view` "" is kZUpFrontView turned to SPEC §5's
/// three-quarter view (kDefaultAzimuthDeg, kDefaultElevationDeg), an axis view ("+x" … "-z",
/// parseViewDirection) looks straight along its axis (0, 0); a given azimuth or elevation
/// replaces that turn.
Camera framedCamera(const std::array<double, 6>& box, const std::string& view,
                    std::optional<double> azimuthDeg, std::optional<double> elevationDeg,
                    double zoom, double viewAngleDeg, double aspect);

/// A point is visible when the TF's opacity at its mean is at least this share of the TF's
/// largest opacity (faint fog does not count).
inline constexpr double kVisibleOpacityShare = 0.1;
/// The share of visible points the box may leave out on each side of each axis (stray noise).
inline constexpr double kVisibleTrim = 0.001;

/// The bounding box (world units) of the visible grid points (by their mean value and
/// kVisibleOpacityShare), trimmed by kVisibleTrim per side and axis, padded by one spacing and
/// clipped to model.bounds; model.bounds when no point is visible.
/// *anyVisible (when given) says whether any point was.
std::array<double, 6> visibleBounds(const ModelVolume& model, const TransferFunction1D& tf,
                                    bool* anyVisible = nullptr);
/// The same for a 2D TF, by its largest opacity over y at each x (the value alone decides).
std::array<double, 6> visibleBounds(const ModelVolume& model, const TransferFunction2D& tf,
                                    bool* anyVisible = nullptr);

}  // namespace udvr
