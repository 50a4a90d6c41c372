#pragma once
// Trilinear reconstruction (SPEC §1, §3), written once over a value type T: double (the exact
// path and probe), float (one GPU thread) or lanes::Vf (16 samples of the CPU batch). A cell is
// the base voxel of the 8 corners holding an index-space point and the fractional position in
// it; values blend by lerps along x, then y, then z, so equal corners give exactly equal values.
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <type_traits>

#include "udvr/util/check.h"
#include "udvr/util/grid.h"
#include "udvr/util/lanes.h"

namespace udvr {

/// Index-space geometry of a grid's trilinear cells; device-copyable.
struct CellGeometry {
    int dims[3] = {1, 1, 1};
    float maxIndex[3] = {0, 0, 0};       // dims − 1: index-space clamp (SPEC §3)
    int maxBase[3] = {0, 0, 0};          // last cell's base index: max(dims − 2, 0)
    std::int64_t stride[3] = {1, 1, 1};  // voxels per unit step along each axis
    std::int64_t next[3] = {0, 0, 0};    // offset of the +1 neighbour (0 on a 1-point axis)
    int next32[3] = {0, 0, 0};           // the same as int (batched lanes)
    int stride32[3] = {0, 0, 0};
    bool fitsInt32 = false;  // every voxel index fits an int32 lane

    CellGeometry() = default;
    explicit CellGeometry(const std::array<int, 3>& d) {
        for (int a = 0; a < 3; ++a) dims[a] = d[a];
        stride[0] = 1;
        stride[1] = d[0];
        stride[2] = static_cast<std::int64_t>(d[0]) * d[1];
        for (int a = 0; a < 3; ++a) {
            maxIndex[a] = static_cast<float>(d[a] - 1);
            maxBase[a] = d[a] > 2 ? d[a] - 2 : 0;
            next[a] = d[a] > 1 ? stride[a] : 0;
        }
        fitsInt32 = stride[2] * d[2] < std::numeric_limits<std::int32_t>::max();
        if (fitsInt32)
            for (int a = 0; a < 3; ++a) {
                next32[a] = static_cast<int>(next[a]);
                stride32[a] = static_cast<int>(stride[a]);
            }
    }
    explicit CellGeometry(const Grid3& g) : CellGeometry(g.dims) {}
};

/// Voxel indices: int64 for scalars, int32 lanes for the batch.
template <class T>
using IndexOf = std::conditional_t<lanes::kIsVector<T>, lanes::Vi, std::int64_t>;
/// Index-space positions: float for scalars (the ray loop's precision), float lanes.
template <class T>
using PositionOf = std::conditional_t<lanes::kIsVector<T>, lanes::Vf, float>;

/// The cell of a sample: base voxel and fractional position (each in [0, 1]).
template <class T>
struct Cell {
    IndexOf<T> base{};
    T fx{}, fy{}, fz{};
};

/// The cell at index-space point (x, y, z), clamped into the grid per axis; points on the last
/// plane use the cell below it with fraction 1 (0 on a 1-point axis).
template <class T>
UDVR_CPU_GPU UDVR_INLINE Cell<T> cellAt(const CellGeometry& g, PositionOf<T> x, PositionOf<T> y,
                                        PositionOf<T> z) {
    using P = PositionOf<T>;
    const P p[3] = {x, y, z};
    Cell<T> c;
    T* frac[3] = {&c.fx, &c.fy, &c.fz};
    c.base = IndexOf<T>{};
    for (int a = 0; a < 3; ++a) {
        const P v =
            lanes::min(lanes::max(p[a], lanes::splat<P>(0.f)), lanes::splat<P>(g.maxIndex[a]));
        if constexpr (lanes::kIsVector<T>) {
            const lanes::Vi i = lanes::min(lanes::truncToInt(v), lanes::splati(g.maxBase[a]));
            *frac[a] = v - lanes::toFloat(i);
            c.base += i * g.stride32[a];
        } else {
            const int i = lanes::min(static_cast<int>(v), g.maxBase[a]);
            *frac[a] = static_cast<T>(v - static_cast<float>(i));
            c.base += static_cast<std::int64_t>(i) * g.stride[a];
        }
    }
    return c;
}

/// Lane l of a batch's cells as a scalar cell.
UDVR_CPU_GPU UDVR_INLINE Cell<double> laneCell(const Cell<lanes::Vf>& c, int l) {
    return Cell<double>{c.base[l], c.fx[l], c.fy[l], c.fz[l]};
}

/// u + f·(v − u).
template <class T>
UDVR_CPU_GPU UDVR_INLINE T lerp(T u, T v, T f) {
    return lanes::fma(f, v - u, u);
}

/// Trilinear blend of a per-voxel quantity: `edge(offset, v0, v1)` gives the quantity at the
/// ends of the x-edge starting at voxel base + offset (v1 at its +x neighbour), for the lanes
/// that need it. Lerps along x, then y, then z.
template <class T, class Edge>
UDVR_CPU_GPU UDVR_INLINE T trilinearBy(const CellGeometry& g, const Cell<T>& c, const Edge& edge) {
    const std::int64_t oy = g.next[1], oz = g.next[2];
    const std::int64_t offsets[4] = {0, oy, oz, oz + oy};
    T row[4];
    for (int r = 0; r < 4; ++r) {
        T v0, v1;
        edge(offsets[r], v0, v1);
        row[r] = lerp(v0, v1, c.fx);
    }
    return lerp(lerp(row[0], row[1], c.fy), lerp(row[2], row[3], c.fy), c.fz);
}

/// The x-edge ends of `values` (perVoxel floats per voxel, the first read) at voxel
/// base + offset: plain loads for scalars, gathers for lanes (64-bit pairs when x-neighbours
/// are adjacent floats).
template <class T>
UDVR_CPU_GPU UDVR_INLINE void edgeOf(const CellGeometry& g, const float* values, int perVoxel,
                                     const IndexOf<T>& base, std::int64_t offset,
                                     lanes::MaskOf<T> live, T& v0, T& v1) {
    if constexpr (lanes::kIsVector<T>) {
        const lanes::Vi idx = base + static_cast<int>(offset);
        if (perVoxel == 1 && g.next32[0] == 1) {
            lanes::gatherPair(values, idx, live, v0, v1);
        } else {
            v0 = lanes::gather(values, idx * perVoxel, live);
            v1 = lanes::gather(values, (idx + g.next32[0]) * perVoxel, live);
        }
    } else {
        (void)live;
        const std::int64_t v = base + offset;
        v0 = static_cast<T>(values[v * perVoxel]);
        v1 = static_cast<T>(values[(v + g.next[0]) * perVoxel]);
    }
}

/// Σ_c w_c·values[c] by lerps (SPEC §3 `mean`): `values` holds perVoxel floats per voxel and the
/// first of each is read (pass values + i for the i'th).
template <class T>
UDVR_CPU_GPU UDVR_INLINE T trilinear(const CellGeometry& g, const float* values, int perVoxel,
                                     const Cell<T>& c, lanes::MaskOf<T> live) {
    return trilinearBy(g, c, [&](std::int64_t o, T& v0, T& v1) {
        edgeOf<T>(g, values, perVoxel, c.base, o, live, v0, v1);
    });
}

/// The 8 trilinear weights w_c = (1−f or f) per axis, corner c = (c&1, c>>1&1, c>>2&1).
template <class T>
UDVR_CPU_GPU UDVR_INLINE void trilinearWeights(const Cell<T>& c, T w[8]) {
    const T one = lanes::splat<T>(1);
    for (int k = 0; k < 8; ++k)
        w[k] = ((k & 1) ? c.fx : one - c.fx) * ((k & 2) ? c.fy : one - c.fy) *
               ((k & 4) ? c.fz : one - c.fz);
}

/// Grid indices (i, j, k) of a linear voxel index.
UDVR_CPU_GPU UDVR_INLINE std::array<int, 3> voxelIndices(const CellGeometry& g, std::int64_t v) {
    return {static_cast<int>(v % g.stride[1]), static_cast<int>((v / g.stride[1]) % g.dims[1]),
            static_cast<int>(v / g.stride[2])};
}

/// Linear voxel index of corner k of a scalar cell.
UDVR_CPU_GPU UDVR_INLINE std::int64_t cornerVoxel(const CellGeometry& g, std::int64_t base, int k) {
    return base + ((k & 1) ? g.next[0] : 0) + ((k & 2) ? g.next[1] : 0) + ((k & 4) ? g.next[2] : 0);
}

}  // namespace udvr
