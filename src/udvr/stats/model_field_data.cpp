#include "udvr/stats/model_field_data.h"

namespace udvr {

std::vector<ModelFieldDatum> modelFieldData(const ModelVolume& model, bool hasQuantiles,
                                            bool hasGmm) {
    std::vector<ModelFieldDatum> out;
    out.push_back({"quantile_count", hasQuantiles ? model.quantileCount : 0});
    if (hasQuantiles) {
        std::vector<double> levels(static_cast<std::size_t>(model.quantileCount) + 1);
        for (int j = 0; j <= model.quantileCount; ++j)
            levels[static_cast<std::size_t>(j)] = model.quantileLevel(j);
        out.push_back({"quantile_levels", std::move(levels)});
    }
    out.push_back({"density", model.density});
    out.push_back({"bandwidth", std::vector<double>{model.bandwidth}});
    out.push_back({"bandwidth_rule", model.bandwidthRule});
    out.push_back({"tail_eps", std::vector<double>{model.tailEps}});
    out.push_back({"samples_per_voxel", model.samplesPerVoxel});
    out.push_back({"downsample", model.downsample});
    out.push_back({"bounds", std::vector<double>(model.bounds.begin(), model.bounds.end())});
    out.push_back({"full_res_min_spacing", std::vector<double>{model.fullResMinSpacing}});
    out.push_back({"gmm_components", hasGmm ? model.gmmComponents : 0});
    out.push_back({"source", model.source});
    if (!model.defaultTf.empty()) out.push_back({"default_tf", model.defaultTf});
    return out;
}

}  // namespace udvr
