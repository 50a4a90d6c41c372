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
#include <variant>

#include "udvr/classify/expected_tf2.h"
#include "udvr/classify/expected_tf2_bivariate.h"
#include "udvr/classify/model_kernels.h"
#include "udvr/reconstruct/quantile_interp.h"

namespace udvr {

/// A field's distribution at a cell as pieces into a MarginalSink (SPEC §3, model by model).
struct FieldMarginal {
    const Cell<double>& cell;
    MarginalSink& sink;

    void operator()(const MeanKernel& k) const { sink.point(k.load<double>(cell, true), 1.0); }
    void operator()(const UniformKernel& k) const {
        const UniformSum u = k.sumAt(cell);
        if (u.n == 0)
            sink.point(u.shift, 1.0);
        else
            sink.boxSpline(u, 1.0);
    }
    void operator()(const GaussianKernel& k) const {
        double mu, sigma;
        k.paramsAt<double>(cell, true, mu, sigma);
        normalOrPoint(mu, sigma, 1.0);
    }
    void operator()(const GmmOrderedKernel& k) const {
        double pi[kMaxKernelGmmComponents], mu[kMaxKernelGmmComponents],
            sigma[kMaxKernelGmmComponents];
        k.componentsAt<double>(cell, true, pi, mu, sigma);  // π normalised (all 0: no mass)
        for (int i = 0; i < k.components; ++i)
            if (pi[i] != 0.0) normalOrPoint(mu[i], sigma[i], pi[i]);
    }
    void operator()(const QuantileRangeKernel& k) const {
        // Rank population j0 … j1: each quantile uniform between its boundaries (Eq. 2), with
        // its share of the population's mass.
        const double inv = k.levels.inverseTotal<double>(k.j1 - k.j0 + 1);
        double a = boundaryAt<double>(k.geometry, k.boundaries, k.stride, k.j0, cell, true);
        for (int j = k.j0 + 1; j <= k.j1; ++j) {
            const double b = boundaryAt<double>(k.geometry, k.boundaries, k.stride, j, cell, true);
            const double mass = k.levels.mass(j - k.j0) * inv;
            if (b > a)
                sink.uniform(a, b, mass);
            else
                sink.point(a, mass);
            a = b;
        }
    }
    void operator()(const QuantileMeanKernel& k) const {
        // Eq. 5: point masses at the midpoints, p_j ∝ m_j/w_j (or m_j; m_j the quantile's mass,
        // 1 for even levels); quantiles of width ≤ zeroWidth are infinitely dense and share all
        // the weight by their masses (SPEC §4). Two passes: the weights' total, then the points.
        const int q = k.q, stride = q + 1;
        const auto width = [&](int j) {
            return widthAt<double>(k.geometry, k.quantiles, stride, j, cell, true);
        };
        bool anyZero = false;
        for (int j = 0; k.densityWeights && j < q; ++j)
            anyZero = anyZero || width(j) <= k.zeroWidth;
        const auto weight = [&](int j) {
            const double m = k.levels.mass(j + 1);
            if (!k.densityWeights) return m;
            const double w = width(j);
            return anyZero ? (w <= k.zeroWidth ? m : 0.0) : m / w;
        };
        double total = 0.0;
        for (int j = 0; j < q; ++j) total += weight(j);
        double a = boundaryAt<double>(k.geometry, k.quantiles, stride, 0, cell, true);
        for (int j = 0; j < q; ++j) {
            const double b = boundaryAt<double>(k.geometry, k.quantiles, stride, j + 1, cell, true);
            const double p = weight(j) / total;
            if (p != 0.0) sink.point(0.5 * (a + b), p);
            a = b;
        }
    }

    void operator()(const MembersKernel& k) const {
        for (int i = 0; i < k.n; ++i) sink.point(k.memberAt<double>(i, cell, true), 1.0 / k.n);
    }

  private:
    void normalOrPoint(double mu, double sigma, double mass) const {
        if (sigma > 0.0)
            sink.normal(mu, sigma, mass);
        else
            sink.point(mu, mass);
    }
};

/// Bivariate mean field and ground truth: TF2(x̄, ȳ), on lanes.
struct BivariateMean2DKernel : GridKernel, detail::ClassifyInLoad {
    Tf2Raster<double> tfExact;
    Tf2Raster<float> tfFast;
    const float* first;   // one value per grid point: x
    const float* second;  // y

    BivariateMean2DKernel(const Grid3& grid, const float* a, const float* b,
                          const Tf2Raster<double>& exact, const Tf2Raster<float>& fast)
        : GridKernel(grid), tfExact(exact), tfFast(fast), first(a), second(b) {}
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

/// Bivariate fields of any other model: each field's distribution (FieldMarginal) as per-cell
/// moments along its raster axis, then E[TF2] exactly (expectedTf2Independent), in double
/// (lanes and float threads take the double body).
struct Bivariate2DKernel : GridKernel, detail::ClassifyInLoad {
    Tf2Raster<double> tf;
    RasterAxis axisX, axisY;
    const int* rowCells;  // per row of cells: first and last cell with α > 0 (Tf2Rasters)
    int firstRow, lastRow;
    AnyKernel first, second;  // the fields' 1D kernels, for their reconstruction only

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
    /// E[(α·r, α·g, α·b, α)] at a cell. Moments only where they can meet α > 0: y over the rows
    /// of cells with α > 0, then x over the cells with α > 0 in the rows y reaches.
    void classifyAt(const Cell<double>& c, double out[4]) const {
        thread_local AxisMoments x, y;  // reused: reset() clears what the last sample touched
        for (int ch = 0; ch < 4; ++ch) out[ch] = 0.0;
        y.reset(axisY, firstRow, lastRow);
        if (lastRow < firstRow) return;
        std::visit(FieldMarginal{c, y}, second);
        int lo = axisX.cells(), hi = -1;
        for (int j = y.lo(); j <= y.hi(); ++j) {
            lo = std::min(lo, rowCells[2 * j]);
            hi = std::max(hi, rowCells[2 * j + 1]);
        }
        if (hi < lo) return;
        x.reset(axisX, lo, hi);
        std::visit(FieldMarginal{c, x}, first);
        expectedTf2Independent(tf, x, y, out, rowCells);
    }
    /// Mean and standard deviation of the second field at a cell (probe output).
    MarginalSummary secondAt(const Cell<double>& c) const {
        MarginalSummary s;
        std::visit(FieldMarginal{c, s}, second);
        return s;
    }
    template <class T>
    Classified<T> load(const Cell<T>& c, lanes::MaskOf<T> live) const {
        Classified<T> r{};
        if constexpr (std::is_same_v<T, double>)
            classifyAt(c, r.v);
        else
            detail::exactWhere(*this, c, live, r.v);
        return r;
    }
    void voxelSupport(std::size_t voxel, float& lo, float& hi) const {
        std::visit([&](const auto& k) { k.voxelSupport(voxel, lo, hi); }, first);
    }
    void prefetch(int) const {}
};

}  // namespace udvr
