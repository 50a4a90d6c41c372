#pragma once
// Kernels for bivariate fields with a 2D TF (SPEC §9, the paper's §5.2 fuzzy fiber surfaces):
// x from the first field, y from the second, the fields independent of each other; each field's
// distribution at the sample is its model's of SPEC §3, reconstructed by the model's own 1D
// kernel (model_kernels.h: the same interpolation, one place), so every model with a per-sample
// kernel has a bivariate classification: mean (TF2 at the two means), uniform (the paper's tensor
// product of two box splines), gaussian, gmm-ordered, the quantile-range family (Σ_j Σ_k 1/q²
// × mean of TF2 over [b_j, b_j+1] × [b'_k, b'_k+1]), quantile-mean (TF2 at the pairs of
// midpoints, Eq. 5's weights per field) and the members (a point mass 1/n at each member's
// value). The same interface as the 1D kernels, so the same ray loop and probe serve them.
#include <type_traits>
#include <variant>

#include "udvr/classify/any_kernel.h"
#include "udvr/classify/expected_tf2.h"
#include "udvr/classify/expected_tf2_bivariate.h"
#include "udvr/classify/point_distribution.h"
#include "udvr/reconstruct/quantile_interp.h"

namespace udvr {

/// Bivariate mean field and ground truth: TF2(x̄, ȳ), on lanes.
struct BivariateMean2DKernel : GridKernel, detail::ClassifyInLoad {
    Tf2Raster<double> tfExact;
    Tf2Raster<float> tfFast;
    const float* first;   // one value per grid point: x
    const float* second;  // y

    BivariateMean2DKernel(const Grid3& grid, const float* a, const float* b,
                          const Tf2Raster<double>& exact, const Tf2Raster<float>& fast)
        : GridKernel(grid), tfExact(exact), tfFast(fast), first(a), second(b) {}
    /// The kernel over the fields `first` (x) and `second` (y) for a row of the model table
    /// (model_rows.h): `rasters` (Tf2Rasters, model_families.h) holds the TF2's views, `none` a
    /// TF of α = 0 for the 1D kernels, `family` the row's 1D factory; all outlive it.
    template <class Rasters, class Family>
    static BivariateMean2DKernel make(const ModelView& first, const ModelView& second,
                                      const Rasters& rasters, const TfPiecesStorage&,
                                      const ClassifyOptions&, const Family&) {
        return BivariateMean2DKernel(first.grid, first.mean.data(), second.mean.data(),
                                     rasters.exact, rasters.fast);
    }
    template <class T>
    UDVR_CPU_GPU UDVR_INLINE Classified<T> load(const Cell<T>& c, lanes::MaskOf<T> live) const {
        Classified<T> r;
        const T x = trilinear(geometry, first, 1, c, live),
                y = trilinear(geometry, second, 1, c, live);
        if constexpr (std::is_same_v<lanes::ScalarOf<T>, float>)
            tf2At<T>(tfFast, x, y, live, r.v);
        else
            tf2At<T>(tfExact, x, y, live, r.v);
        detail::keepLive<T>(live, r.v);
        return r;
    }
    void voxelSupport(std::size_t v, float& lo, float& hi) const { lo = hi = first[v]; }
    void prefetch(int v) const {
        prefetchRows(first, v, 1);
        prefetchRows(second, v, 1);
    }
};

/// Bivariate fields of any other model: each field's distribution reconstructed once per sample
/// over the lane type by the row's 1D kernel (its `reconstruct<T>`), then per live lane E[TF2]
/// exactly (expectedTf2Independent) in double, from lane l's distributions as double ones
/// (laneAsDouble, described as per-cell moments along the raster's axes). The double body (probe,
/// references) is the same code with one lane.
struct Bivariate2DKernel : GridKernel, detail::ClassifyInLoad {
    Tf2Raster<double> tf;
    RasterAxis axisX, axisY;
    const int* rowCells;  // per row of cells: first and last cell with α > 0 (Tf2Rasters)
    int firstRow, lastRow;
    AnyKernel first, second;  // the fields' 1D kernels (one type), for their reconstruction only

    Bivariate2DKernel(const Grid3& grid, const Tf2Raster<double>& raster, const int* rows,
                      int rowLo, int rowHi, AnyKernel a, AnyKernel b)
        : GridKernel(grid),
          tf(raster),
          axisX{raster.x0, raster.invDx, raster.width},
          axisY{raster.y0, raster.invDy, raster.height},
          rowCells(rows),
          firstRow(rowLo),
          lastRow(rowHi),
          first(std::move(a)),
          second(std::move(b)) {}
    /// The kernel over the fields `first` (x) and `second` (y) for a row of the model table
    /// (model_rows.h): `rasters` (Tf2Rasters, model_families.h) holds the TF2's views, `none` a
    /// TF of α = 0 for the 1D kernels, `family` the row's 1D factory; all outlive it.
    template <class Rasters, class Family>
    static Bivariate2DKernel make(const ModelView& first, const ModelView& second,
                                  const Rasters& rasters, const TfPiecesStorage& none,
                                  const ClassifyOptions& options, const Family& family) {
        return Bivariate2DKernel(first.grid, rasters.exact, rasters.rowCells.data(),
                                 rasters.firstRow, rasters.lastRow,
                                 family.makeKernel(first, none, options, family),
                                 family.makeKernel(second, none, options, family));
    }
    /// Both fields' distributions at a cell over T, each reconstructed once by the row's 1D
    /// kernel, handed to use(x, y).
    template <class T, class Use>
    void reconstruct(const Cell<T>& c, lanes::MaskOf<T> live, const Use& use) const {
        std::visit(
            [&](const auto& kx) {
                const auto& ky = std::get<std::decay_t<decltype(kx)>>(second);  // the same row
                kx.template reconstruct<T>(c, live, [&](const auto& x) {
                    ky.template reconstruct<T>(c, live, [&](const auto& y) { use(x, y); });
                });
            },
            first);
    }
    /// E[(α·r, α·g, α·b, α)] over two double distributions (x, y). Moments only where they can
    /// meet α > 0: y over the rows of cells with α > 0, then x over the cells with α > 0 in the
    /// rows y reaches.
    template <class DX, class DY>
    void expectationOver(const DX& dx, const DY& dy, double out[4]) const {
        thread_local AxisMoments x, y;  // reused: reset() clears what the last sample touched
        for (int ch = 0; ch < 4; ++ch) out[ch] = 0.0;
        y.reset(axisY, firstRow, lastRow);
        if (lastRow < firstRow) return;
        describe(dy, y);
        int lo = axisX.cells(), hi = -1;
        for (int j = y.lo(); j <= y.hi(); ++j) {
            lo = std::min(lo, rowCells[2 * j]);
            hi = std::max(hi, rowCells[2 * j + 1]);
        }
        if (hi < lo) return;
        x.reset(axisX, lo, hi);
        describe(dx, x);
        expectedTf2Independent(tf, x, y, out, rowCells);
    }
    /// Mean and standard deviation of the second field at a cell (probe output).
    DistributionMoments secondAt(const Cell<double>& c) const {
        DistributionMoments s;
        distributionAt(second, c, s);
        return s;
    }
    /// Lanes and float threads: loadOverLanes, except batches whose lane gathers would pass
    /// int32 (lanesFit) and `members` in either field, which take the double body. members'
    /// lanes are exact (the lane test holds loadOverLanes to 2e−6) but slower: each lane's
    /// values re-read the batch's rows (laneAsDouble(EqualMasses)), 1.2–1.9× the double body
    /// (members × members, 64³ tangle, 16²–32², one thread).
    template <class T>
    Classified<T> load(const Cell<T>& c, lanes::MaskOf<T> live) const {
        if constexpr (!std::is_same_v<T, double>) {
            bool fit = true;
            if constexpr (lanes::kIsVector<T>) {
                const auto fits = [](const AnyKernel& k) {
                    return std::visit([](const auto& one) { return one.lanesFit(); }, k);
                };
                fit = fits(first) && fits(second);
            }
            if (!fit || std::holds_alternative<MembersKernel>(first) ||
                std::holds_alternative<MembersKernel>(second)) {
                Classified<T> r{};
                detail::exactWhere(*this, c, live, r.v);
                return r;
            }
        }
        return loadOverLanes<T>(c, live);
    }
    /// Both fields reconstructed over T once, then expectationOver per live lane (0 in the others).
    template <class T>
    Classified<T> loadOverLanes(const Cell<T>& c, lanes::MaskOf<T> live) const {
        Classified<T> r{};
        reconstruct<T>(c, live, [&](const auto& x, const auto& y) {
            detail::inDoublePerLane<T>(live, r.v, [&](int l, double v[4]) {
                expectationOver(laneAsDouble(x, l), laneAsDouble(y, l), v);
            });
        });
        return r;
    }
    void voxelSupport(std::size_t voxel, float& lo, float& hi) const {
        std::visit([&](const auto& k) { k.voxelSupport(voxel, lo, hi); }, first);
    }
    void prefetch(int) const {}
};

}  // namespace udvr
