#include "udvr/stats/model_volume.h"

#include <utility>

#include "udvr/util/check.h"
#include "udvr/util/parallel.h"

namespace udvr {

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
