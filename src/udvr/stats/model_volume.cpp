#include "udvr/stats/model_volume.h"

#include <cmath>
#include <cstdlib>

#include "udvr/util/check.h"

namespace udvr {

std::vector<double> normalizedQuantileLevels(const std::vector<double>& levels, int q,
                                             const std::string& what) {
    if (levels.empty()) return {};
    if (static_cast<int>(levels.size()) != q + 1)
        UDVR_FAIL(what << " has " << levels.size() << " levels for " << q
                       << " quantiles; expected q + 1 = " << q + 1);
    if (levels.front() != 0.0 || levels.back() != 1.0)
        UDVR_FAIL(what << " must start at 0 and end at 1 (got " << levels.front() << " … "
                       << levels.back() << ")");
    bool even = true;
    for (std::size_t j = 0; j < levels.size(); ++j) {
        if (!std::isfinite(levels[j]) || (j > 0 && !(levels[j] > levels[j - 1])))
            UDVR_FAIL(what << " must be strictly increasing finite numbers; level " << j << " is "
                           << levels[j]);
        even = even && std::abs(levels[j] - static_cast<double>(j) / q) <= 1e-9;
    }
    return even ? std::vector<double>{} : levels;
}

ModelVolume modelFromField(const ScalarField& field) {
    ModelVolume m;
    m.grid = field.grid;
    m.mean = field.values;
    m.min = field.values;
    m.max = field.values;
    m.stddev.assign(field.values.size(), 0.f);
    m.samplesPerVoxel = 1;
    m.downsample = 0;
    m.bounds = field.grid.bounds();
    m.fullResMinSpacing = field.grid.minSpacing();
    m.source = field.name;
    return m;
}

}  // namespace udvr
