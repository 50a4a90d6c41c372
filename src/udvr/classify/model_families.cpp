#include "udvr/classify/model_families.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <mutex>
#include <string>

#include "udvr/reconstruct/gradient_field.h"
#include "udvr/util/check.h"

namespace udvr {
namespace {

// Arrays per option set.
unsigned meanArrays(const ClassifyOptions&) { return kArrayMean; }
unsigned momentArrays(const ClassifyOptions&) { return kArrayMean | kArrayStddev; }
unsigned uniformArrays(const ClassifyOptions& o) {
    return o.uniformMinMax ? kArrayMin | kArrayMax : kArrayMean | kArrayStddev;
}
unsigned gmmArrays(const ClassifyOptions&) { return kArrayGmm; }
unsigned quantileArrays(const ClassifyOptions&) { return kArrayQuantiles; }
unsigned iqrArrays(const ClassifyOptions&) { return kArrayIqr; }
unsigned memberArrays(const ClassifyOptions&) { return kArrayMembers; }

// Floats per voxel.
double one(int, int, int) { return 1.0; }
double two(int, int, int) { return 2.0; }
double perComponent(int, int k, int) { return 3.0 * k; }
double perBoundary(int q, int, int) { return q + 1.0; }
double perMember(int, int, int n) { return n; }

double span(const ModelView& model, const ClassifyOptions& options = {}) {
    if (options.dataSpan > 0.0) return options.dataSpan;
    const auto range = modelDataRange(model);
    return range.second - range.first;
}

AnyKernel makeMean(const ModelView& m, const TfPiecesStorage& tf, const ClassifyOptions&,
                   const ModelFamily&) {
    return MeanKernel(m.grid, m.mean.data(), tf);
}
AnyKernel makeUniform(const ModelView& m, const TfPiecesStorage& tf, const ClassifyOptions& o,
                      const ModelFamily& f) {
    const double s = span(m, o);
    return UniformKernel(m.grid, o.uniformMinMax ? m.min.data() : m.mean.data(),
                         o.uniformMinMax ? m.max.data() : m.stddev.data(), o.uniformMinMax,
                         kUniformTinyWidth * s, tf, f.kind == ModelKind::UniformExact,
                         kUniformPointWidth * s);
}
AnyKernel makeGaussian(const ModelView& m, const TfPiecesStorage& tf, const ClassifyOptions&,
                       const ModelFamily&) {
    return GaussianKernel(m.grid, m.mean.data(), m.stddev.data(), tf);
}
AnyKernel makeGmmOrdered(const ModelView& m, const TfPiecesStorage& tf, const ClassifyOptions&,
                         const ModelFamily&) {
    return GmmOrderedKernel(m.grid, m.gmm.data(), m.gmmComponents, tf);
}
AnyKernel makeQuantileRange(const ModelView& m, const TfPiecesStorage& tf, const ClassifyOptions& o,
                            const ModelFamily& f) {
    const auto pop = quantilePopulation(f.kind, m, o);
    return QuantileRangeKernel(m.grid, m.quantiles.data(), m.quantileCount + 1, pop.first,
                               pop.second, m.levelsOrNull(), tf);
}
AnyKernel makeIqr(const ModelView& m, const TfPiecesStorage& tf, const ClassifyOptions&,
                  const ModelFamily&) {
    return QuantileRangeKernel(m.grid, m.iqr.data(), 2, 0, 1, nullptr, tf);
}
AnyKernel makeQuantileMean(const ModelView& m, const TfPiecesStorage& tf, const ClassifyOptions& o,
                           const ModelFamily& f) {
    return QuantileMeanKernel(m.grid, m.quantiles.data(), m.quantileCount, m.levelsOrNull(),
                              f.kind == ModelKind::QuantileMean, kQuantileZeroWidth * span(m, o),
                              tf);
}
AnyKernel makeMembers(const ModelView& m, const TfPiecesStorage& tf, const ClassifyOptions&,
                      const ModelFamily&) {
    return MembersKernel(m.grid, m.members.data(), m.memberCount, tf);
}

// 2D kernels (SPEC §9).
AnyKernel2D makeMean2D(const ModelView& m, Tf2Setup& s, const ClassifyOptions&,
                       const ModelFamily&) {
    return Mean2DKernel(
        m.grid, s.gradients.of(m.grid, m.mean.data(), 1, 0, 1, GradientLayout::ValueRows).data(),
        s.exact, s.fast);
}
AnyKernel2D makeGaussian2D(const ModelView& m, Tf2Setup& s, const ClassifyOptions&,
                           const ModelFamily& f) {
    return Gaussian2DKernel(m.grid, m.mean.data(), m.stddev.data(), s.exact, s.fast,
                            s.meanGradientPlanes(),
                            f.kind == ModelKind::GaussianExact ? nullptr : s.blurTables());
}
AnyKernel2D makeUniform2D(const ModelView& m, Tf2Setup& s, const ClassifyOptions& o,
                          const ModelFamily& f) {
    return Uniform2DKernel(m.grid, o.uniformMinMax ? m.min.data() : m.mean.data(),
                           o.uniformMinMax ? m.max.data() : m.stddev.data(), o.uniformMinMax,
                           f.kind == ModelKind::UniformExact, kUniformTinyWidth * span(m, o),
                           s.exact, s.fast, s.meanGradientPlanes(),
                           f.kind == ModelKind::UniformExact ? nullptr : s.blurTables());
}
// Boundaries lo … hi of an array with `stride` floats per voxel, with their grid gradients.
AnyKernel2D quantile2D(const ModelView& m, Tf2Setup& s, const ClassifyOptions& o, const float* data,
                       int stride, int lo, int hi, const double* levels, bool quantileMean,
                       bool density) {
    if (hi - lo + 1 > kMaxBoundaries2D)
        UDVR_FAIL("2D transfer functions handle at most "
                  << kMaxBoundaries2D - 1 << " quantiles, the model has " << hi - lo);
    const float* gradients =
        s.gradients
            .of(m.grid, data, stride, lo, hi - lo + 1, GradientLayout::VoxelRows, m.mean.data())
            .data();
    return Quantile2DKernel(m.grid, data, stride, lo, hi, gradients, levels, quantileMean, density,
                            kQuantileZeroWidth * span(m, o), s.exact, s.fast);
}
AnyKernel2D makeQuantileRange2D(const ModelView& m, Tf2Setup& s, const ClassifyOptions& o,
                                const ModelFamily& f) {
    const auto pop = quantilePopulation(f.kind, m, o);
    return quantile2D(m, s, o, m.quantiles.data(), m.quantileCount + 1, pop.first, pop.second,
                      m.levelsOrNull(), false, false);
}
AnyKernel2D makeIqr2D(const ModelView& m, Tf2Setup& s, const ClassifyOptions& o,
                      const ModelFamily&) {
    return quantile2D(m, s, o, m.iqr.data(), 2, 0, 1, nullptr, false, false);
}
AnyKernel2D makeQuantileMean2D(const ModelView& m, Tf2Setup& s, const ClassifyOptions& o,
                               const ModelFamily& f) {
    return quantile2D(m, s, o, m.quantiles.data(), m.quantileCount + 1, 0, m.quantileCount,
                      m.levelsOrNull(), true, f.kind == ModelKind::QuantileMean);
}

// kind, name, arrays, floats per voxel, population, label shows q, realizations, kernel,
// 2D kernel, frame cost (ns per pixel × step: 1D, 2D, bivariate; eval/experiment_plan.cpp).
using K = ModelKind;
// clang-format off
constexpr std::array<ModelFamily, 16> kFamilies{{
    {K::Mean, "mean", meanArrays, one, {0, 0}, false, false, makeMean, makeMean2D, {8.9, 15.0, 11.9}},
    {K::Uniform, "uniform", uniformArrays, two, {0, 0}, false, false, makeUniform, makeUniform2D, {150.0, 5000.0, 1160.0}},
    {K::Gaussian, "gaussian", momentArrays, two, {0, 0}, false, false, makeGaussian, makeGaussian2D, {39.0, 200.0, 1210.0}},
    {K::GmmOrdered, "gmm-ordered", gmmArrays, perComponent, {0, 0}, false, false, makeGmmOrdered, nullptr, {82.0, 0, 0}},
    {K::GmmMc, "gmm-mc", gmmArrays, perComponent, {0, 0}, false, true, nullptr, nullptr, {7.95, 0, 0}},
    {K::QuantileRange, "quantile-range", quantileArrays, perBoundary, {0, 1}, true, false, makeQuantileRange, makeQuantileRange2D, {18.8, 89.0, 263.0}},
    {K::QuantileMean, "quantile-mean", quantileArrays, perBoundary, {0, 0}, true, false, makeQuantileMean, makeQuantileMean2D, {13.0, 20.0, 161.0}},
    {K::QuantileMeanMass, "quantile-mean-mass", quantileArrays, perBoundary, {0, 0}, true, false, makeQuantileMean, makeQuantileMean2D, {13.0, 20.0, 161.0}},
    {K::Iqr, "iqr", iqrArrays, two, {0, 0}, false, false, makeIqr, makeIqr2D, {9.3, 16.0, 0}},
    {K::QuartileLower, "quartile-lower", quantileArrays, perBoundary, {0, .25}, false, false, makeQuantileRange, makeQuantileRange2D, {18.8, 89.0, 263.0}},
    {K::QuartileMiddle, "quartile-middle", quantileArrays, perBoundary, {.25, .75}, false, false, makeQuantileRange, makeQuantileRange2D, {18.8, 89.0, 263.0}},
    {K::QuartileUpper, "quartile-upper", quantileArrays, perBoundary, {.75, 1}, false, false, makeQuantileRange, makeQuantileRange2D, {18.8, 89.0, 263.0}},
    {K::Members, "members", memberArrays, perMember, {0, 0}, false, false, makeMembers, nullptr, {2.65, 0, 0}},
    {K::UniformFast, "uniform-fast", uniformArrays, two, {0, 0}, false, false, makeUniform, makeUniform2D, {150.0, 5000.0, 1160.0}},
    {K::UniformExact, "uniform-exact", uniformArrays, two, {0, 0}, false, false, makeUniform, makeUniform2D, {925.0, 5000.0, 1160.0}},
    {K::GaussianExact, "gaussian-exact", momentArrays, two, {0, 0}, false, false, makeGaussian, makeGaussian2D, {39.0, 6690.0, 1210.0}},
}};
// clang-format on

// An array of SPEC §7: its bit, name, values per voxel and how to rebuild a model that lacks it.
struct ArrayInfo {
    ModelArray bit;
    const char* name;
    std::span<const float> ModelView::*values;
    const char* hint;
};
constexpr std::array<ArrayInfo, 8> kArrays{{
    {kArrayMean, "mean", &ModelView::mean, "rebuild it with `udvr build`"},
    {kArrayStddev, "stddev", &ModelView::stddev, "rebuild it with `udvr build`"},
    {kArrayMin, "min", &ModelView::min, "rebuild it with `udvr build`"},
    {kArrayMax, "max", &ModelView::max, "rebuild it with `udvr build`"},
    {kArrayQuantiles, "quantiles", &ModelView::quantiles, "build with --quantiles Q"},
    {kArrayIqr, "iqr", &ModelView::iqr, "rebuild it with `udvr build`"},
    {kArrayGmm, "gmm", &ModelView::gmm, "build with --gmm K"},
    {kArrayMembers, "members", &ModelView::members, "read the ensemble itself"},
}};

std::size_t valuesPerVoxel(ModelArray a, const ModelView& m) {
    switch (a) {
        case kArrayQuantiles:
            return static_cast<std::size_t>(m.quantileCount) + 1;
        case kArrayIqr:
            return 2;
        case kArrayGmm:
            return 3 * static_cast<std::size_t>(m.gmmComponents);
        case kArrayMembers:
            return static_cast<std::size_t>(m.memberCount);
        default:
            return 1;
    }
}

}  // namespace

Tf2Rasters::Tf2Rasters(const TransferFunction2D& tf) {
    exact.width = fast.width = tf.width;
    exact.height = fast.height = tf.height;
    exact.x0 = tf.x0;
    exact.y0 = tf.y0;
    exact.invDx = (tf.width - 1) / (tf.x1 - tf.x0);
    exact.invDy = (tf.height - 1) / (tf.y1 - tf.y0);
    exact.rgba = fast.rgba = tf.rgba.data();
    fast.x0 = static_cast<float>(exact.x0);
    fast.y0 = static_cast<float>(exact.y0);
    fast.invDx = static_cast<float>(exact.invDx);
    fast.invDy = static_cast<float>(exact.invDy);
    cellEmptyDistance = tf.emptyCellDistances();
    exact.cellEmptyDistance = fast.cellEmptyDistance = cellEmptyDistance.data();
    // Runs pay where they are long: each piece of a walk by runs costs two more gathers and a
    // crossed y line a new run lookup (64³ tangle, quantile-range 512²: the 1D TF as a 1024×2
    // TF2, 7.3 opaque cells per run, 3.7 → 1.0 s; data/tf2/tangle.json at 256², 1.9 per run,
    // 4.2 → 6.8 s). Used where an opaque run averages ≥ kMinMeanRunCells cells.
    constexpr std::size_t kMinMeanRunCells = 3;
    cellRuns = tf.linearCellRuns(kTf2RunTolerance);
    std::size_t opaqueCells = 0, opaqueRuns = 0;
    const std::size_t cells = static_cast<std::size_t>(tf.width) - 1;
    for (std::size_t c = 0; c < cellEmptyDistance.size(); ++c)
        if (cellEmptyDistance[c] == 0.f) {
            ++opaqueCells;
            opaqueRuns += cellRuns[2 * c] == static_cast<float>(c % cells);  // a run's first cell
        }
    if (opaqueCells >= kMinMeanRunCells * opaqueRuns)
        fast.cellRun = cellRuns.data();
    else
        cellRuns.clear();
    // The banded walk's prefix tables (exact, O(min(x, y crossings)) pieces a segment) for the
    // float view; the double view keeps the cell-by-cell walk (probe, references).
    if (static_cast<std::size_t>(tf.width) * tf.height <= kMaxTf2BandPrefixPoints) {
        bandPrefix = tf.bandPrefixMoments();
        fast.bandPrefix = bandPrefix.data();
        // Per band, its cells with α > 0 (first, one past the last): x bands, then y bands.
        const int cx = tf.width - 1, cy = tf.height - 1;
        bandCells.assign(2 * static_cast<std::size_t>(cx + cy), 0.f);
        const auto opaque = [&](int i, int j) {
            return cellEmptyDistance[static_cast<std::size_t>(j) * cx + i] == 0.f;
        };
        for (int i = 0; i < cx; ++i)
            for (int j = 0; j < cy; ++j)
                if (opaque(i, j)) {
                    if (bandCells[2 * i + 1] == 0.f) bandCells[2 * i] = static_cast<float>(j);
                    bandCells[2 * i + 1] = static_cast<float>(j + 1);
                }
        for (int j = 0; j < cy; ++j)
            for (int i = 0; i < cx; ++i)
                if (opaque(i, j)) {
                    float* b = bandCells.data() + 2 * (static_cast<std::size_t>(cx) + j);
                    if (b[1] == 0.f) b[0] = static_cast<float>(i);
                    b[1] = static_cast<float>(i + 1);
                }
        fast.bandCells = bandCells.data();
        int firstCol = cx, lastCol = -1, firstBand = cy, lastBand = -1;
        for (int i = 0; i < cx; ++i)
            if (bandCells[2 * i + 1] > 0.f) firstCol = std::min(firstCol, i), lastCol = i;
        for (int j = 0; j < cy; ++j)
            if (bandCells[2 * (static_cast<std::size_t>(cx) + j) + 1] > 0.f)
                firstBand = std::min(firstBand, j), lastBand = j;
        constexpr float inf = std::numeric_limits<float>::infinity();
        if (lastCol < 0) {
            fast.opaqueBox[0] = fast.opaqueBox[2] = 1.f;
            fast.opaqueBox[1] = fast.opaqueBox[3] = 0.f;
        } else {
            fast.opaqueBox[0] = firstCol == 0 ? -inf : static_cast<float>(firstCol);
            fast.opaqueBox[1] = lastCol + 1 == cx ? inf : static_cast<float>(lastCol + 1);
            fast.opaqueBox[2] = firstBand == 0 ? -inf : static_cast<float>(firstBand);
            fast.opaqueBox[3] = lastBand + 1 == cy ? inf : static_cast<float>(lastBand + 1);
        }
    }
    const int cw = tf.width - 1, rows = tf.height - 1;
    columnEmptyRun.assign(static_cast<std::size_t>(cw), 0.f);
    for (int i = cw - 1; i >= 0; --i) {
        bool empty = true;
        for (int j = 0; j < rows && empty; ++j)
            empty = cellEmptyDistance[static_cast<std::size_t>(j) * cw + i] != 0.f;
        if (empty) columnEmptyRun[i] = 1.f + (i + 1 < cw ? columnEmptyRun[i + 1] : 0.f);
    }
    exact.columnEmptyRun = fast.columnEmptyRun = columnEmptyRun.data();
    rowCells.assign(2 * static_cast<std::size_t>(rows), 0);
    for (int j = 0; j < rows; ++j) {
        int first = cw, last = -1;
        for (int i = 0; i < cw; ++i)
            if (cellEmptyDistance[static_cast<std::size_t>(j) * cw + i] == 0.f) {
                first = std::min(first, i);
                last = i;
            }
        rowCells[2 * j] = first;
        rowCells[2 * j + 1] = last;
        if (last >= 0) {
            if (lastRow < 0) firstRow = j;
            lastRow = j;
        }
    }
    // The closed form over identical rows (Tf2Raster::rowPrefix) pays where at least half of the
    // bands with α > 0 are such stretches (a 1D TF sampled as a TF2: all of them); elsewhere
    // its per-vertex lookups only add to the walk (data/tf2/tangle.json: 84 of 255 bands
    // identical, none with α > 0, quantile-range 11.0 → 11.6 s with the tables).
    if (static_cast<std::size_t>(tf.width) * tf.height <= kMaxTf2RowPrefixPoints) {
        std::vector<float> same = tf.identicalRowsUpTo();
        int opaque = 0, flat = 0;
        for (int j = 0; j < rows; ++j)
            if (rowCells[2 * j + 1] >= 0) {
                ++opaque;
                flat += same[j] > static_cast<float>(j);
            }
        if (opaque > 0 && 2 * flat >= opaque) {
            rowSameUpTo = std::move(same);
            rowPrefix = tf.rowPrefixIntegrals();
            fast.rowSameUpTo = rowSameUpTo.data();
            fast.rowPrefix = rowPrefix.data();
        }
    }
}

Tf2Setup::Tf2Setup(const TransferFunction2D& tf, const ModelView& m, GradientCache& cache)
    : Tf2Rasters(tf), model(m), gradients(cache) {}

const Tf2BlurTables* Tf2Setup::blurTables() {
    if (!blurTables_) {
        static std::mutex mutex;
        static std::shared_ptr<const Tf2BlurTables> last;
        const std::lock_guard<std::mutex> lock(mutex);
        if (!last || !last->matches(exact)) last = std::make_shared<const Tf2BlurTables>(exact);
        blurTables_ = last;
    }
    return blurTables_.get();
}

MeanGradientView Tf2Setup::meanGradientPlanes() {
    return {gradients.of(model.grid, model.mean.data(), 1, 0, 1).data(), 1,
            model.grid.pointCount()};
}

void checkSameGrid(const ModelView& first, const ModelView& second) {
    const Grid3 &a = first.grid, &b = second.grid;
    if (a.dims != b.dims)
        UDVR_FAIL("the second field's grid is " << b.dims[0] << "x" << b.dims[1] << "x" << b.dims[2]
                                                << ", the first's " << a.dims[0] << "x" << a.dims[1]
                                                << "x" << a.dims[2]
                                                << ": bivariate fields need one grid");
    for (int axis = 0; axis < 3; ++axis) {
        const double scale = std::max(std::fabs(a.spacing[axis]), 1e-300);
        if (std::fabs(a.spacing[axis] - b.spacing[axis]) > 1e-6 * scale ||
            std::fabs(a.origin[axis] - b.origin[axis]) > 1e-6 * scale)
            UDVR_FAIL("the second field's origin or spacing differs from the first's along axis "
                      << "xyz"[axis] << ": bivariate fields need one grid");
    }
}

const TransferFunction1D& reconstructionOnlyTf() {
    static const TransferFunction1D none = [] {
        TransferFunction1D tf;
        tf.colorX = {0.0};
        tf.color = {{0.0, 0.0, 0.0}};
        tf.opacityX = {0.0};
        tf.opacity = {0.0};
        return tf;
    }();
    return none;
}

std::span<const ModelFamily> modelFamilies() { return kFamilies; }

const ModelFamily& modelFamily(ModelKind kind) {
    for (const ModelFamily& f : kFamilies)
        if (f.kind == kind) return f;
    UDVR_FAIL("unknown model kind " << static_cast<int>(kind));
}

const ModelFamily& familyWithKernel(const ModelView& model, ModelKind kind,
                                    const ClassifyOptions& options, const char* what) {
    checkModelHasArrays(model, kind, options);
    const ModelFamily& family = modelFamily(kind);
    if (!family.makeKernel)
        UDVR_FAIL("model '" << family.name << "' has no " << what
                            << ": it is rendered as the average of mean-field realizations");
    return family;
}

std::pair<int, int> quantilePopulation(ModelKind kind, const ModelView& model,
                                       const ClassifyOptions& options) {
    const ModelFamily& f = modelFamily(kind);
    if (!(f.population.second > f.population.first))
        UDVR_FAIL("model '" << f.name << "' is not a quantile-range model");
    const int q = model.quantileCount;
    const bool whole = f.population.first == 0.0 && f.population.second == 1.0;
    if (!whole && !model.quantileLevels.empty()) {
        const int lo = model.boundaryAtLevel(f.population.first);
        const int hi = model.boundaryAtLevel(f.population.second);
        if (lo < 0 || hi < 0)
            UDVR_FAIL("model '" << f.name << "' needs boundaries at the levels "
                                << f.population.first << " and " << f.population.second
                                << ", which the model's --quantile-levels lack");
        return {lo, hi};
    }
    const int d = options.quartileDivisor;
    if (!whole && (d <= 0 || q % d != 0))
        UDVR_FAIL("model '" << f.name << "' needs a quantile count divisible by " << d
                            << ", but the model has q = " << q
                            << " (rebuild with e.g. --quantiles 8)");
    return {static_cast<int>(f.population.first * q + 0.5),
            static_cast<int>(f.population.second * q + 0.5)};
}

void checkModelHasArrays(const ModelView& model, ModelKind kind, const ClassifyOptions& options) {
    const std::size_t n = model.voxelCount();
    if (n == 0) UDVR_FAIL("model has an empty grid");
    const ModelFamily& f = modelFamily(kind);
    const unsigned need = f.arrays(options);
    for (const ArrayInfo& a : kArrays) {
        if (!(need & a.bit)) continue;
        const std::span<const float> v = model.*a.values;
        const std::size_t per = valuesPerVoxel(a.bit, model);
        // No file holds the members: the model or field was read, not the ensemble.
        if (a.bit == kArrayMembers && (v.empty() || per == 0))
            UDVR_FAIL("model '"
                      << f.name
                      << "' needs an ensemble (a .nc with a member dimension, member files or a "
                         "quoted glob), not "
                      << (model.samplesPerVoxel == 1 ? "a single field" : "a model file")
                      << ": it averages the TF over the members themselves");
        // A plain field read as a model (modelFromField: one sample per voxel) has mean, min,
        // max and a zero stddev; the distribution arrays come only from `udvr build`.
        if ((v.empty() || per == 0) && model.samplesPerVoxel == 1)
            UDVR_FAIL("the input is a plain field (one value per voxel), not a model: model '"
                      << f.name << "' needs the '" << a.name
                      << "' array of a model built with `udvr build` (from an ensemble, or from "
                         "one field with --downsample K), or use --model mean");
        if (v.empty() || per == 0)
            UDVR_FAIL("model has no '" << a.name << "' array, needed by model '" << f.name << "' ("
                                       << a.hint << ")");
        if (v.size() != n * per)
            UDVR_FAIL("model array '" << a.name << "' has " << v.size() << " values, expected "
                                      << n * per);
    }
    if ((need & kArrayGmm) && f.makeKernel && model.gmmComponents > kMaxKernelGmmComponents)
        UDVR_FAIL("model has " << model.gmmComponents << " GMM components; at most "
                               << kMaxKernelGmmComponents << " are supported");
    if (f.population.second > f.population.first) quantilePopulation(kind, model, options);
}

}  // namespace udvr
