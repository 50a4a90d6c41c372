#include "udvr/stats/model_volume.h"

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

}  // namespace udvr
