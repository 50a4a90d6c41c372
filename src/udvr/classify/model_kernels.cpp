#include "udvr/classify/model_kernels.h"

#include <algorithm>
#include <limits>

namespace udvr {
std::pair<double, double> modelDataRange(const ModelView& model) {
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

}  // namespace udvr
