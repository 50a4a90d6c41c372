#pragma once
// The model families of SPEC §3–4 in one table: the rows of model_rows.h (the one list of
// models: name, help, arrays, population, …; model_kind.h) with the factories of the kernels
// they name. Everything that differs by model (render, probe, checks, help and error texts, the
// experiments' tables) reads the row; model_rows.h says what adding a model takes.
#include <array>
#include <memory>
#include <span>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include "udvr/classify/any_kernel.h"
#include "udvr/classify/model_kernels_bivariate.h"
#include "udvr/classify/model_kind.h"
#include "udvr/classify/transfer_function_2d.h"
#include "udvr/reconstruct/gradient_field.h"
#include "udvr/stats/model_view.h"

namespace udvr {

/// Largest deviation from linear (per channel, α and colour in [0, 1]) that the float raster's
/// cell runs allow (TransferFunction2D::linearCellRuns): segment means over runs then differ
/// from the cell-by-cell walk by at most this (α) and twice it (α·c).
inline constexpr double kTf2RunTolerance = 1e-6;
/// Largest raster (points) that gets the row prefix integrals (8 floats per point: 128 MiB).
inline constexpr std::size_t kMaxTf2RowPrefixPoints = std::size_t{1} << 22;

/// Largest raster (points) that gets the banded walk's prefix tables
/// (TransferFunction2D::bandPrefixMoments: 2 × 21 doubles per point, 84 MiB at this size, 512²;
/// 22 MB for 256²); larger ones walk cell by cell. Bounds what a TF2 edit (serve) allocates.
inline constexpr std::size_t kMaxTf2BandPrefixPoints = std::size_t{1} << 18;

/// How the float view of a TF2 (Tf2Rasters::fast) walks a segment: cell by cell (by runs of
/// linear cells where they pay), or banded (the prefix tables of TransferFunction2D::
/// bandPrefixMoments: O(min(x, y crossings)) pieces a segment, exact as well). Renders walk
/// cell by cell: on the 64³ tangle with data/tf2/tangle.json the banded walk measured
/// 10–25 % slower (quantile-range, iqr; AVX-512 and x86-64-v3, docs/models.md), and its tables
/// cost 22 MB and ~40 ms per TF2 at 256². The banded walk stays for its tests and benchmarks.
enum class Tf2SegmentWalk { cellByCell, banded };

/// Views of a validated TF2 for the kernels: the raster over double and float, with the
/// distances of empty cells (TransferFunction2D::emptyCellDistances); the float view also
/// walks segments by runs of linear cells (kTf2RunTolerance) or banded (Tf2SegmentWalk), the
/// double one cell by cell. `tf` must outlive them.
struct Tf2Rasters {
    Tf2Raster<double> exact;
    Tf2Raster<float> fast;
    std::vector<float> cellEmptyDistance;
    std::vector<float> columnEmptyRun;  // Tf2Raster::columnEmptyRun
    std::vector<float> cellOpaqueSum;   // Tf2Raster::cellOpaqueSum
    std::vector<float> cellRuns;
    /// The float view's closed form for segments that see one row's function
    /// (Tf2Raster::rowSameUpTo, rowPrefix): where at least half of the bands with α > 0 have
    /// identical rows, up to kMaxTf2RowPrefixPoints; else empty.
    std::vector<float> rowSameUpTo, rowPrefix;
    /// The float view's banded walk tables (Tf2Raster::bandPrefix) with Tf2SegmentWalk::banded,
    /// up to kMaxTf2BandPrefixPoints; else empty.
    std::vector<double> bandPrefix;
    std::vector<float> bandCells;  // Tf2Raster::bandCells, with bandPrefix
    /// Per row of cells j: the first and last cell with α > 0 at a corner (first > last: none);
    /// and the first and last such row.
    std::vector<int> rowCells;
    int firstRow = 0, lastRow = -1;

    explicit Tf2Rasters(const TransferFunction2D& tf,
                        Tf2SegmentWalk walk = Tf2SegmentWalk::cellByCell);
    Tf2Rasters(const Tf2Rasters&) = delete;
    Tf2Rasters& operator=(const Tf2Rasters&) = delete;
};

/// A TF2 with its views (Tf2Rasters), which point into the copy of the TF2 it owns.
struct Tf2RasterSet {
    TransferFunction2D tf;
    Tf2Rasters rasters;

    explicit Tf2RasterSet(const TransferFunction2D& t) : tf(t), rasters(tf) {}
};

/// Largest TF2 (points) whose views sharedTf2Rasters keeps between calls (512²: ~3 MiB of
/// cell tables and 8 MiB of row prefix integrals, held after the last frame).
inline constexpr std::size_t kMaxCachedTf2Points = std::size_t{1} << 18;

/// The views of `tf` (validated by the caller). Up to kMaxCachedTf2Points: the last ones made
/// in the process where they are of an equal TF2 (size, domain and every point), else new ones
/// kept for the next call; frames of one TF2 (a camera move in `udvr serve`, `--frames`, a
/// probe after a render) then build the tables (Tf2Rasters: 15–120 ms for a 256² TF2) once.
/// Larger TF2s get views of their own over `tf` itself, which must then outlive them.
std::shared_ptr<const Tf2Rasters> sharedTf2Rasters(const TransferFunction2D& tf);

/// What a 2D kernel points into: the TF2 raster's views (sharedTf2Rasters) and the grid
/// gradients it blends (from `gradients`, which outlives the setup).
struct Tf2Setup {
  private:
    std::shared_ptr<const Tf2Rasters> held_;  // keeps the views alive (sharedTf2Rasters)

  public:
    const Tf2Rasters& rasters;
    const Tf2Raster<double>& exact;  // rasters.exact
    const Tf2Raster<float>& fast;    // rasters.fast
    const ModelView& model;
    GradientCache& gradients;

    /// Views of `tf` (validated by the caller) over `model`; `tf`, `model` and `cache` outlive
    /// the setup.
    Tf2Setup(const TransferFunction2D& tf, const ModelView& model, GradientCache& cache);
    Tf2Setup(const Tf2Setup&) = delete;
    Tf2Setup& operator=(const Tf2Setup&) = delete;
    /// The `mean` array's grid gradients as planes (computed on first use).
    MeanGradientView meanGradientPlanes();
    /// The fast 2D gaussian's and uniform's prefiltered tables of the TF2: the last ones made
    /// in the process where they are of the same raster (Tf2BlurTables::matches: frames of
    /// one TF2), else new ones; each blur pair's table is built when a sample first needs it.
    const Tf2BlurTables* blurTables();

  private:
    std::shared_ptr<const Tf2BlurTables> blurTables_;
};

#define UDVR_MODEL_KERNEL_BIVARIATE(Enumerator, Kernel1D, Kernel2D, KernelBivariate, ...) \
    , KernelBivariate
/// A bivariate field's kernel with a 2D TF (SPEC §9): x from `first`, y from `second`.
using AnyBivariateKernel = typename detail::KernelVariant<std::variant<> UDVR_MODEL_ROWS(
    UDVR_MODEL_KERNEL_BIVARIATE)>::type;
#undef UDVR_MODEL_KERNEL_BIVARIATE

/// A row of the model table (model_rows.h): its data (ModelRow) and the factories of the
/// kernels it names, null for a TF kind the model has no kernel for.
struct ModelFamily : ModelRow {
    /// The kernel over `model` with the TF pieces `tf` (both outlive it). Null for gmm-mc.
    AnyKernel (*makeKernel)(const ModelView& model, const TfPiecesStorage& tf,
                            const ClassifyOptions& options, const ModelFamily& family);
    /// The kernel with a 2D TF (SPEC §9) over `model`, filling the gradients it needs in
    /// `setup` (which outlives it). Null where SPEC §9 gives the model no 2D classification.
    AnyKernel2D (*makeKernel2D)(const ModelView& model, Tf2Setup& setup,
                                const ClassifyOptions& options, const ModelFamily& family);
    /// The kernel for bivariate fields (SPEC §9 `--second`): x from `first`, y from `second`,
    /// with the TF2's views `rasters` and `none` (reconstructionOnlyTf's pieces, for the 1D
    /// kernels), which outlive it. Null where the model has none (gmm-mc).
    AnyBivariateKernel (*makeBivariate)(const ModelView& first, const ModelView& second,
                                        const Tf2Rasters& rasters, const TfPiecesStorage& none,
                                        const ClassifyOptions& options, const ModelFamily& family);

    /// Arrays the classification reads (for the options given).
    unsigned arraysWith(const ClassifyOptions& options) const {
        return arraysFor(options.uniformMinMax);
    }
};

/// Every model family, in the order of SPEC §3–4.
std::span<const ModelFamily> modelFamilies();
/// The row of a model.
const ModelFamily& modelFamily(ModelKind kind);
/// The names of the arrays in `arrays` (ModelArray bits; SPEC §7's, and "members" for the
/// ensemble itself), in bit order: a row's `arrays` as the Python module's models() gives it.
std::vector<std::string_view> modelArrayNames(unsigned arrays);

/// The row of `kind` after checking that `model` has the arrays it needs and that it has a
/// per-sample kernel; else UdvrError (gmm-mc: "has no <what>: it is rendered as the average of
/// mean-field realizations").
const ModelFamily& familyWithKernel(const ModelView& model, ModelKind kind,
                                    const ClassifyOptions& options, const char* what);

/// Call f(kernel) with the kernel for `kind` built over `model` and `tf` (the TF pieces live
/// for the call). Throws UdvrError when the model lacks an array the kind needs, or for gmm-mc,
/// which has no per-sample kernel (render only: its realizations are mean fields).
template <class F>
void withKernel(const ModelView& model, ModelKind kind, const TransferFunction1D& tf,
                const ClassifyOptions& options, F&& f) {
    const ModelFamily& family = familyWithKernel(model, kind, options, "per-sample kernel");
    const TfPiecesStorage pieces(tf);
    std::visit(f, family.makeKernel(model, pieces, options, family));
}

/// withKernel for a 2D TF (SPEC §9): f(kernel) with the model's 2D kernel, its grid gradients
/// from `cache` (kept between frames) or computed for the call. `tf` must be validated
/// (TransferFunction2D::validate). Throws UdvrError for models without one or a model without a
/// `mean` array (n̂ needs it).
template <class F>
void withKernel2D(const ModelView& model, ModelKind kind, const TransferFunction2D& tf,
                  const ClassifyOptions& options, F&& f, GradientCache* cache = nullptr) {
    checkModelHasArrays(model, kind, options);
    checkModelHasArrays(model, ModelKind::Mean, options);
    const ModelFamily& family = modelFamily(kind);
    if (!family.makeKernel2D)
        UDVR_FAIL("model '" << family.name
                            << "' has no 2D transfer-function classification yet (built: "
                            << modelNames(true) << ")");
    GradientCache local;
    Tf2Setup setup(tf, model, cache ? *cache : local);
    std::visit(f, family.makeKernel2D(model, setup, options, family));
}

/// Throws UdvrError unless the two models share one grid (dimensions, origin and spacing).
void checkSameGrid(const ModelView& first, const ModelView& second);

/// A TF of α = 0 everywhere, for kernels built for their reconstruction only.
const TransferFunction1D& reconstructionOnlyTf();

/// withKernel for bivariate fields (SPEC §9 `--second`): f(kernel) with x from `first` and y
/// from `second`, both under model `kind` (each field's zero-width thresholds scaled by its own
/// data range unless options.dataSpan is set). `tf` must be validated. Throws UdvrError for
/// grids that differ, a model lacking the arrays `kind` needs, or gmm-mc.
template <class F>
void withKernelBivariate(const ModelView& first, const ModelView& second, ModelKind kind,
                         const TransferFunction2D& tf, const ClassifyOptions& options, F&& f) {
    checkSameGrid(first, second);
    const ModelFamily& family = familyWithKernel(first, kind, options, "bivariate classification");
    checkModelHasArrays(second, kind, options);
    if (!family.makeBivariate)
        UDVR_FAIL("model '" << family.name << "' has no bivariate classification yet");
    const std::shared_ptr<const Tf2Rasters> views = sharedTf2Rasters(tf);
    const TfPiecesStorage none(reconstructionOnlyTf());
    std::visit(f, family.makeBivariate(first, second, *views, none, options, family));
}

/// withKernel with default options.
template <class F>
void withKernel(const ModelView& model, ModelKind kind, const TransferFunction1D& tf, F&& f) {
    withKernel(model, kind, tf, ClassifyOptions{}, std::forward<F>(f));
}

}  // namespace udvr
