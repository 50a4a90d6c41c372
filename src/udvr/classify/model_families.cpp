#include "udvr/classify/model_families.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <mutex>
#include <string>
#include <tuple>
#include <type_traits>

#include "udvr/reconstruct/gradient_field.h"
#include "udvr/util/check.h"

namespace udvr {
namespace {

// A factory of the table: a function of the type of the (null) pointer passed, one of
// ModelFamily's, that builds the row's kernel type K by K::make; null for NoKernel.
template <class K, class R, class... Args>
constexpr auto factory(R (*)(Args...)) -> R (*)(Args...) {
    if constexpr (std::is_same_v<K, NoKernel>)
        return nullptr;
    else
        return [](Args... args) -> R { return K::make(args...); };
}
using Make1D = decltype(ModelFamily::makeKernel);
using Make2D = decltype(ModelFamily::makeKernel2D);
using MakeBivariate = decltype(ModelFamily::makeBivariate);

// The rows of model_rows.h with their kernels' factories, in row order.
constexpr ModelFamily kFamilies[] = {
#define UDVR_MODEL_FAMILY(Enumerator, Kernel1D, Kernel2D, KernelBivariate, ...) \
    ModelFamily{modelRow(ModelKind::Enumerator), factory<Kernel1D>(Make1D{}),   \
                factory<Kernel2D>(Make2D{}), factory<KernelBivariate>(MakeBivariate{})},
    UDVR_MODEL_ROWS(UDVR_MODEL_FAMILY)
#undef UDVR_MODEL_FAMILY
};
static_assert(std::size(kFamilies) == kModelCount);
static_assert([] {
    for (std::size_t i = 0; i < kModelCount; ++i)
        if (static_cast<std::size_t>(kFamilies[i].kind) != i) return false;
    return true;
}());

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

Tf2Rasters::Tf2Rasters(const TransferFunction2D& tf, Tf2SegmentWalk walk) {
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
    // With Tf2SegmentWalk::banded, the banded walk's prefix tables (exact, O(min(x, y
    // crossings)) pieces a segment) for the float view; the double view keeps the cell-by-cell
    // walk (probe, references).
    if (walk == Tf2SegmentWalk::banded &&
        static_cast<std::size_t>(tf.width) * tf.height <= kMaxTf2BandPrefixPoints) {
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
    }
    // The box of raster coordinates outside which α = 0 (Tf2Raster::opaqueBox): the banded walk
    // walks only the part of a segment inside, the pooled cell walk trims its items to it.
    {
        const int cx = tf.width - 1, cy = tf.height - 1;
        int firstCol = cx, lastCol = -1, firstBand = cy, lastBand = -1;
        for (int j = 0; j < cy; ++j)
            for (int i = 0; i < cx; ++i)
                if (cellEmptyDistance[static_cast<std::size_t>(j) * cx + i] == 0.f) {
                    firstCol = std::min(firstCol, i), lastCol = std::max(lastCol, i);
                    firstBand = std::min(firstBand, j), lastBand = std::max(lastBand, j);
                }
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
    // The summed-area table of the cells with α > 0 (exact in float up to 2^24 cells).
    opaqueCellSums(tf.rgba.data(), tf.width, tf.height, cellOpaqueSum);
    exact.cellOpaqueSum = fast.cellOpaqueSum = cellOpaqueSum.data();
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

std::shared_ptr<const Tf2Rasters> sharedTf2Rasters(const TransferFunction2D& tf) {
    if (static_cast<std::size_t>(tf.width) * tf.height > kMaxCachedTf2Points)
        return std::make_shared<const Tf2Rasters>(tf);
    static std::mutex mutex;
    static std::shared_ptr<const Tf2RasterSet> last;
    // Compared and built under the lock, on purpose: the setups of one TF2 that come together (a
    // frame's threads, serve's requests after an edit) build its views once, not once each, and
    // at most one set (≤ ~100 MiB) is alive; a setup of another TF2 waits for that build (~40 ms
    // at 256²; the comparison reads ≤ 2^18 points).
    const std::lock_guard<std::mutex> lock(mutex);
    const auto same = [&](const TransferFunction2D& t) {
        return t.width == tf.width && t.height == tf.height && t.x0 == tf.x0 && t.x1 == tf.x1 &&
               t.y0 == tf.y0 && t.y1 == tf.y1 && t.rgba == tf.rgba;
    };
    if (!last || !same(last->tf)) {
        last.reset();  // the old set's memory goes back before the new one is built
        last = std::make_shared<const Tf2RasterSet>(tf);
    }
    return {last, &last->rasters};  // shares the set's ownership
}

Tf2Setup::Tf2Setup(const TransferFunction2D& tf, const ModelView& m, GradientCache& cache)
    : held_(sharedTf2Rasters(tf)),
      rasters(*held_),
      exact(rasters.exact),
      fast(rasters.fast),
      model(m),
      gradients(cache) {}

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

std::vector<std::string_view> modelArrayNames(unsigned arrays) {
    std::vector<std::string_view> names;
    for (const ArrayInfo& a : kArrays)
        if (arrays & a.bit) names.emplace_back(a.name);
    return names;
}

const ModelFamily& modelFamily(ModelKind kind) {
    const auto i = static_cast<std::size_t>(kind);
    if (i >= kModelCount) UDVR_FAIL("unknown model kind " << static_cast<int>(kind));
    return kFamilies[i];
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

QuantileBoundarySource quantileBoundariesOf(const ModelView& model, const ModelRow& row,
                                            const ClassifyOptions& options) {
    if (row.arrays & kArrayIqr) return {model.iqr.data(), 2, 0, 1, nullptr};
    QuantileBoundarySource b{model.quantiles.data(), model.quantileCount + 1, 0,
                             model.quantileCount, model.levelsOrNull()};
    if (row.quantileMeanWeights == QuantileMeanWeights::None) {
        std::tie(b.lo, b.hi) = quantilePopulation(row.kind, model, options);
    } else {
        b.densityWeights = row.quantileMeanWeights == QuantileMeanWeights::Density;
        b.zeroWidth = kQuantileZeroWidth * dataSpan(model, options);
    }
    return b;
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
    const unsigned need = f.arraysWith(options);
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
