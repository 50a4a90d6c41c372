#pragma once
// Widgets of 2D transfer functions (SPEC §9) and their rasterisation onto a TransferFunction2D.
// x is the value (or field 1), y the gradient magnitude (or field 2), both in data units. Each
// widget has a colour and a peak opacity a (per unit distance, as the 1D TF's) and an opacity
// α_w(x, y) ∈ [0, a]; overlapping widgets combine as α = 1 − Π(1 − α_w) and
// c = Σ α_w c_w / Σ α_w (c = 0 where every α_w = 0).
#include <array>
#include <variant>
#include <vector>

#include "udvr/classify/transfer_function_2d.h"

namespace udvr {

/// α = a inside the closed rectangle [x0, x1] × [y0, y1], 0 outside.
struct Tf2Box {
    std::array<double, 2> x{0.0, 1.0}, y{0.0, 1.0};  // x0 ≤ x1, y0 ≤ y1
};

/// Kniss et al. 2001's value × gradient-magnitude triangle: apex at (ax, ay), the top edge at
/// y = top, `width` wide (full width in x, centred on ax). Inside where y lies between ay and
/// top and |x − ax| ≤ h(y) = (width/2)·(y − ay)/(top − ay). Tent falloff: α = a·(1 − |x − ax|/h(y))
/// (1 on the centre line x = ax, 0 on the slanted edges); flat: α = a inside.
struct Tf2Triangle {
    std::array<double, 2> apex{0.0, 0.0};
    double top = 1.0;    // ≠ apex y (top < apex y turns the triangle upside down)
    double width = 1.0;  // > 0
    bool flat = false;
};

/// Gaussian ellipse: α = a·exp(−d²/2), d the Mahalanobis distance from `center` with standard
/// deviations sigma along axes rotated `angleDeg` (counter-clockwise, sx's axis from +x);
/// α = 0 where d > cutoff.
struct Tf2Ellipse {
    std::array<double, 2> center{0.0, 0.0};
    std::array<double, 2> sigma{1.0, 1.0};  // > 0
    double angleDeg = 0.0;
    double cutoff = 3.0;  // in σ, > 0
};

/// A band around a polyline (fuzzy fiber surfaces): d = min over the segments (or the point, for
/// one point) of the distance in the scaled plane (x/hx, y/hy); box profile: α = a where d ≤ 1;
/// tent: α = a·max(0, 1 − d).
struct Tf2Band {
    std::vector<std::array<double, 2>> points;  // ≥ 1
    std::array<double, 2> halfWidth{1.0, 1.0};  // hx, hy > 0
    bool tent = false;
};

struct Tf2Widget {
    std::variant<Tf2Box, Tf2Triangle, Tf2Ellipse, Tf2Band> shape;
    std::array<double, 4> rgba{1.0, 1.0, 1.0, 1.0};  // colour and peak opacity a, in [0, 1]
};

/// α_w(x, y) of one widget, in [0, a].
double widgetOpacity(const Tf2Widget& w, double x, double y);

/// Rasterise onto width × height points over [x0, x1] × [y0, y1] (point (i, j) at
/// x0 + i·(x1 − x0)/(W − 1), y0 + j·(y1 − y0)/(H − 1)), combining overlaps as above. The result
/// is validated (W, H ≥ 2, a finite non-empty domain).
TransferFunction2D rasterizeWidgets(const std::vector<Tf2Widget>& widgets, int width, int height,
                                    const std::array<double, 4>& domain);

}  // namespace udvr
