#pragma once
// The exact mean of a raster TF2 along segments (SPEC §9), the walk chosen by what the raster
// holds (segmentWalkOf): the banded walk where Tf2Raster::bandPrefix is set (tf2_banded_walk.h),
// else the walk over the raster lines a segment crosses, per cell or per run of cells
// (tf2_cell_walk.h); the closed form of segments inside rows of constant TF2 is
// tf2_row_constant.h. Sources hand the walks their segments (tf2_walk_lines.h: one segment;
// expected_tf2.h: one polyline, or the pooled segments of a batch). Over T ∈ {double, float,
// lanes::Vf}.
#include "udvr/classify/tf2_banded_walk.h"
#include "udvr/classify/tf2_cell_walk.h"
#include "udvr/classify/tf2_raster.h"
#include "udvr/classify/tf2_row_constant.h"
#include "udvr/classify/tf2_walk_lines.h"

namespace udvr::detail {

/// segmentWalk, by runs where r.cellRun is set; bandedWalk where r.bandPrefix is.
template <class T, class Real, class Source>
UDVR_CPU_GPU UDVR_INLINE void segmentWalkOf(const Tf2Raster<Real>& r, Source& source,
                                            lanes::MaskOf<T> live, T out[4]) {
    if (r.bandPrefix)
        bandedWalk<T>(r, source, live, out);
    else if (r.cellRun)
        segmentWalk<true, T>(r, source, live, out);
    else
        segmentWalk<false, T>(r, source, live, out);
}

}  // namespace udvr::detail
