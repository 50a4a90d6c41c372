#pragma once
// Ray generation for the VTK-style Camera of render.h (SPEC §5): one ray per pixel centre,
// pixel (0,0) at the top-left, vertical view angle, aspect = width / height.
#include <array>

#include "udvr/render/render.h"

namespace udvr {

/// An orthonormal camera basis plus the projection, ready to generate rays. World units.
struct CameraFrame {
    std::array<double, 3> eye;      // camera position
    std::array<double, 3> forward;  // unit direction of projection (focal point − position)
    std::array<double, 3> right;    // unit, VTK's "view sideways" = up × (−forward)
    std::array<double, 3> up;       // unit, orthogonalised view-up
    bool parallel = false;
    double halfHeight = 0.0;  // tan(angle/2) (perspective) or parallelScale (orthographic)
    double aspect = 1.0;      // width / height
    int width = 0, height = 0;

    /// Ray through the centre of pixel (px, py): origin and unit direction, world units.
    void ray(int px, int py, std::array<double, 3>& origin, std::array<double, 3>& dir) const;
};

/// Basis of `camera` as VTK's view transform builds it (vtkPerspectiveTransform::SetupCamera);
/// throws UdvrError for a degenerate camera (position = focal point, view-up ∥ view direction,
/// view angle outside (0, 180), parallel scale ≤ 0, empty image).
CameraFrame makeCameraFrame(const Camera& camera, int width, int height);

/// Ray/box intersection (slab test) in world units; returns false when the line misses.
/// bounds = xmin,xmax,ymin,ymax,zmin,zmax; tNear/tFar are distances along the unit `dir`.
bool intersectBox(const std::array<double, 6>& bounds, const std::array<double, 3>& origin,
                  const std::array<double, 3>& dir, double& tNear, double& tFar);

}  // namespace udvr
