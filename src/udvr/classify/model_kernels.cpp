#include "udvr/classify/model_kernels.h"

#include <algorithm>
#include <limits>

namespace udvr {
namespace {

void requireArray(const std::vector<float>& a, std::size_t expected, const char* name,
                  ModelKind kind) {
    if (a.empty())
        UDVR_FAIL("model has no '" << name << "' array, needed by model '" << modelName(kind)
                                   << "' (rebuild it with `udvr build`)");
    if (a.size() != expected)
        UDVR_FAIL("model array '" << name << "' has " << a.size() << " values, expected "
                                  << expected);
}

}  // namespace

std::pair<double, double> modelDataRange(const ModelVolume& model) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    const std::size_t n = model.voxelCount();
    if (model.hasQuantiles() && model.quantiles.size() == n * (model.quantileCount + 1)) {
        for (std::size_t v = 0; v < n; ++v) {
            const float* b = model.quantilesAt(v);
            lo = std::min(lo, static_cast<double>(b[0]));
            hi = std::max(hi, static_cast<double>(b[model.quantileCount]));
        }
    } else if (!model.min.empty() && !model.max.empty()) {
        for (float v : model.min) lo = std::min(lo, static_cast<double>(v));
        for (float v : model.max) hi = std::max(hi, static_cast<double>(v));
    } else {
        for (float v : model.mean) {
            lo = std::min(lo, static_cast<double>(v));
            hi = std::max(hi, static_cast<double>(v));
        }
    }
    if (!(lo <= hi)) return {0.0, 0.0};
    return {lo, hi};
}

std::pair<int, int> quantilePopulation(ModelKind kind, int q, const ClassifyOptions& options) {
    const int d = options.quartileDivisor;
    switch (kind) {
        case ModelKind::QuantileRange:
            return {0, q};
        case ModelKind::QuartileLower:
        case ModelKind::QuartileMiddle:
        case ModelKind::QuartileUpper:
            if (d <= 0 || q % d != 0)
                UDVR_FAIL("model '" << modelName(kind) << "' needs a quantile count divisible by "
                                    << d << ", but the model has q = " << q
                                    << " (rebuild with e.g. --quantiles 8)");
            if (kind == ModelKind::QuartileLower) return {0, q / 4};
            if (kind == ModelKind::QuartileMiddle) return {q / 4, 3 * q / 4};
            return {3 * q / 4, q};
        default:
            UDVR_FAIL("model '" << modelName(kind) << "' is not a quantile-range model");
    }
}

void checkModelHasArrays(const ModelVolume& model, ModelKind kind, const ClassifyOptions& options) {
    const std::size_t n = model.voxelCount();
    if (n == 0) UDVR_FAIL("model has an empty grid");
    switch (kind) {
        case ModelKind::Mean:
        case ModelKind::GmmMc:
            if (kind == ModelKind::GmmMc) {
                if (!model.hasGmm())
                    UDVR_FAIL("model has no 'gmm' array, needed by model 'gmm-mc'");
                requireArray(model.gmm, n * 3 * model.gmmComponents, "gmm", kind);
            } else {
                requireArray(model.mean, n, "mean", kind);
            }
            return;
        case ModelKind::Uniform:
            if (options.uniformMinMax) {
                requireArray(model.min, n, "min", kind);
                requireArray(model.max, n, "max", kind);
            } else {
                requireArray(model.mean, n, "mean", kind);
                requireArray(model.stddev, n, "stddev", kind);
            }
            return;
        case ModelKind::Gaussian:
            requireArray(model.mean, n, "mean", kind);
            requireArray(model.stddev, n, "stddev", kind);
            return;
        case ModelKind::GmmOrdered:
            if (!model.hasGmm())
                UDVR_FAIL(
                    "model has no 'gmm' array, needed by model 'gmm-ordered' (build with "
                    "--gmm K)");
            if (model.gmmComponents > kMaxKernelGmmComponents)
                UDVR_FAIL("model has " << model.gmmComponents << " GMM components; at most "
                                       << kMaxKernelGmmComponents << " are supported");
            requireArray(model.gmm, n * 3 * model.gmmComponents, "gmm", kind);
            return;
        case ModelKind::Iqr:
            requireArray(model.iqr, 2 * n, "iqr", kind);
            return;
        default:  // the quantile models
            if (!model.hasQuantiles())
                UDVR_FAIL("model has no 'quantiles' array, needed by model '"
                          << modelName(kind) << "' (build with --quantiles Q)");
            requireArray(model.quantiles, n * (model.quantileCount + 1), "quantiles", kind);
            if (kind != ModelKind::QuantileMean && kind != ModelKind::QuantileMeanMass)
                quantilePopulation(kind, model.quantileCount, options);
            return;
    }
}

}  // namespace udvr
