#pragma once
// What the walks of a segment over a raster TF2 share (SPEC §9; tf2_segment_walk.h): the next
// raster line a coordinate crosses and the segment parameter where it does, the lanes still
// walking after a step, and the source of one segment. Over T ∈ {double, float, lanes::Vf}.
#include <cmath>
#include <limits>

#include "udvr/classify/tf2_raster.h"

namespace udvr::detail {

/// The next raster line (integer coordinate in [0, n − 1], n per lane) a coordinate moving from
/// s with slope ds crosses, the step to the one after it (±1), or none (line = −1, step 0).
template <class T>
UDVR_CPU_GPU UDVR_INLINE void firstLineN(T s, T ds, lanes::IntOf<T> n, lanes::IntOf<T>& line,
                                         lanes::IntOf<T>& step) {
    using S = lanes::ScalarOf<T>;
    using I = lanes::IntOf<T>;
    const auto toInt = [](T v) {
        if constexpr (lanes::kIsVector<T>)
            return lanes::truncToInt(v);
        else
            return static_cast<int>(v);
    };
    T nf;
    if constexpr (lanes::kIsVector<T>)
        nf = lanes::toFloat(n);
    else
        nf = static_cast<T>(n);
    // s is clamped to [−1, n] first (NaN → −1): lines lie in [0, n − 1] only, and the int must
    // not wrap.
    const T c = lanes::select(s > S(-1), lanes::min(s, nf), lanes::splat<T>(S(-1)));
    const T fl = [&] {
        if constexpr (lanes::kIsVector<T>) {
            const T tr = lanes::toFloat(lanes::truncToInt(c));
            return lanes::select(tr > c, tr - S(1), tr);
        } else {
            return std::floor(c);
        }
    }();
    const T ce = lanes::select(fl < c, fl + S(1), fl);
    const I up = lanes::max(toInt(fl) + 1, I{} + 0);
    const I down = lanes::min(toInt(ce) - 1, n - 1);
    // A non-finite slope (an overflowed or NaN end) crosses no line: one piece, clamped.
    const auto finite = lanes::abs(ds) <= std::numeric_limits<S>::max();
    const auto rising = finite & (ds > S(0)), falling = finite & (ds < S(0));
    const auto upOk = rising & (up <= n - 1);
    const auto downOk = falling & (down >= 0);
    if constexpr (lanes::kIsVector<T>) {
        line = lanes::select(upOk, up, lanes::select(downOk, down, I{} - 1));
        step = lanes::select(upOk, I{} + 1, lanes::select(downOk, I{} - 1, I{}));
    } else {
        line = upOk ? up : (downOk ? down : -1);
        step = upOk ? 1 : (downOk ? -1 : 0);
    }
}

/// firstLineN with one line count n for all lanes.
template <class T>
UDVR_CPU_GPU UDVR_INLINE void firstLine(T s, T ds, int n, lanes::IntOf<T>& line,
                                        lanes::IntOf<T>& step) {
    firstLineN<T>(s, ds, lanes::IntOf<T>{} + n, line, step);
}
/// A raster line's index as a coordinate of T.
template <class T>
UDVR_CPU_GPU UDVR_INLINE T lineCoordinate(lanes::IntOf<T> line) {
    if constexpr (lanes::kIsVector<T>)
        return lanes::toFloat(line);
    else
        return static_cast<T>(line);
}
/// Segment parameter where the coordinate s0 + u·ds reaches `line` (+∞ for none).
template <class T>
UDVR_CPU_GPU UDVR_INLINE T lineParameter(T s0, T ds, lanes::IntOf<T> line, lanes::IntOf<T> step) {
    using S = lanes::ScalarOf<T>;
    const T u =
        (lineCoordinate<T>(line) - s0) / lanes::select(step != 0, ds, lanes::splat<T>(S(1)));
    return lanes::select(step != 0, u, lanes::splat<T>(std::numeric_limits<S>::infinity()));
}
/// lineParameter from the slope's reciprocal inv = 1/ds (a multiply: the cell walk finds a
/// line per piece; within an ulp or two of the division).
template <class T>
UDVR_CPU_GPU UDVR_INLINE T lineParameterFrom(T s0, T inv, lanes::IntOf<T> line,
                                             lanes::IntOf<T> step) {
    using S = lanes::ScalarOf<T>;
    return lanes::select(step != 0, (lineCoordinate<T>(line) - s0) * inv,
                         lanes::splat<T>(std::numeric_limits<S>::infinity()));
}

/// The lanes still walking after a step of a walk over `source`'s segments (tf2_cell_walk.h,
/// tf2_banded_walk.h): those of `active` in `on` (their segment goes on); with Source::kMany
/// each lane that has just finished its segment hands its sums on (Source::kPooled: flush) and
/// starts its next segment in place (begin(m): the lanes of m that have one).
template <class Source, class M, class T, class Begin>
UDVR_CPU_GPU UDVR_INLINE M stillWalking(Source& source, M active, M on, const Begin& begin,
                                        T out[4]) {
    const M walked = active;
    active = active & on;
    if constexpr (Source::kMany) {
        const M finished = walked & !active;
        if (lanes::anyOf(finished)) {
            if constexpr (Source::kPooled) source.flush(finished, out);
            active = active | begin(finished);
        }
    }
    return active;
}

/// One segment, weight 1: the source of tf2MeanAlongSegment's walk.
template <class T>
struct OneSegment {
    static constexpr bool kMany = false, kPooled = false, kPrepared = false;
    T xa, ya, xb, yb;
    /// Sets the next segment's ends and weight in the lanes of m that have one; returns those.
    UDVR_CPU_GPU UDVR_INLINE lanes::MaskOf<T> next(lanes::MaskOf<T> m, T& pa, T& qa, T& pb, T& qb,
                                                   T& w) const {
        pa = xa, qa = ya, pb = xb, qb = yb;
        w = lanes::splat<T>(lanes::ScalarOf<T>(1));
        return m;
    }
};

}  // namespace udvr::detail
