#pragma once
// Regular grids (SPEC §1): X×Y×Z points, x fastest; world = origin + index·spacing.
#include <array>
#include <cstddef>
#include <cstdint>

#include "udvr/util/check.h"

namespace udvr {

struct Grid3 {
    std::array<int, 3> dims{0, 0, 0};              // points per axis
    std::array<double, 3> origin{0.0, 0.0, 0.0};   // world position of point (0,0,0)
    std::array<double, 3> spacing{1.0, 1.0, 1.0};  // world distance between points, > 0

    /// Number of grid points X·Y·Z.
    std::size_t pointCount() const {
        return static_cast<std::size_t>(dims[0]) * static_cast<std::size_t>(dims[1]) *
               static_cast<std::size_t>(dims[2]);
    }
    /// Linear index of point (i,j,k), x fastest.
    std::size_t index(int i, int j, int k) const {
        return (static_cast<std::size_t>(k) * static_cast<std::size_t>(dims[1]) +
                static_cast<std::size_t>(j)) *
                   static_cast<std::size_t>(dims[0]) +
               static_cast<std::size_t>(i);
    }
    /// World coordinate of a (fractional) index along axis a.
    double world(int axis, double index) const { return origin[axis] + index * spacing[axis]; }
    /// Fractional index of a world coordinate along axis a.
    double indexOf(int axis, double world) const { return (world - origin[axis]) / spacing[axis]; }
    /// World bounding box xmin,xmax,ymin,ymax,zmin,zmax of the grid points.
    std::array<double, 6> bounds() const {
        std::array<double, 6> b{};
        for (int a = 0; a < 3; ++a) {
            b[2 * a] = origin[a];
            b[2 * a + 1] = origin[a] + (dims[a] - 1) * spacing[a];
        }
        return b;
    }
    double minSpacing() const {
        double s = spacing[0];
        if (spacing[1] < s) s = spacing[1];
        if (spacing[2] < s) s = spacing[2];
        return s;
    }
    bool sameShape(const Grid3& o) const { return dims == o.dims; }
};

}  // namespace udvr
