#include "udvr/stats/model_volume.h"

#include <cmath>
#include <cstdlib>
#include <utility>

#include "udvr/util/check.h"
#include "udvr/util/parallel.h"

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

ModelVolume membersModel(Ensemble ensemble) {
    const int n = ensemble.members;
    const std::size_t voxels = ensemble.grid.pointCount();
    UDVR_CHECK_MSG(n >= 1 && ensemble.values.size() == voxels * static_cast<std::size_t>(n),
                   "ensemble size vs members x grid");
    ModelVolume m;
    m.grid = ensemble.grid;
    m.memberCount = n;
    if (ensemble.voxelMajor) {
        m.members = std::move(ensemble.values);
    } else {
        m.members.resize(ensemble.values.size());
        parallelForChunks(voxels, 4096, [&](std::size_t begin, std::size_t end) {
            for (int i = 0; i < n; ++i) {
                const float* member = ensemble.member(i);
                for (std::size_t v = begin; v < end; ++v) m.members[v * n + i] = member[v];
            }
        });
        ensemble.values = {};
    }
    m.mean.resize(voxels);
    parallelForChunks(voxels, 4096, [&](std::size_t begin, std::size_t end) {
        for (std::size_t v = begin; v < end; ++v) {
            double sum = 0.0;
            for (int i = 0; i < n; ++i) sum += m.members[v * n + i];
            m.mean[v] = static_cast<float>(sum / n);
        }
    });
    m.samplesPerVoxel = n;
    m.downsample = 0;
    m.bounds = ensemble.grid.bounds();
    m.fullResMinSpacing = ensemble.grid.minSpacing();
    m.source = ensemble.name;
    return m;
}

}  // namespace udvr
