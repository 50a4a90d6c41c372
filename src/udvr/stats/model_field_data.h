#pragma once
// A model file's field data (SPEC §7) as names and values, in the order it is written: one list
// for every writer — the .vti/.pvti writers of io/ (Debian's VTK) and the ParaView plugin's Build
// Model filter (ParaView's VTK).
#include <string>
#include <variant>
#include <vector>

#include "udvr/stats/model_volume.h"

namespace udvr {

/// One field-data array: an int (VTK int array of one value), doubles (VTK double array) or a
/// string (VTK string array of one value).
struct ModelFieldDatum {
    const char* name;
    std::variant<int, std::vector<double>, std::string> value;
};

/// The field data of a model file of `model` (SPEC §7): quantile_count, quantile_levels (with
/// quantiles), density, bandwidth, bandwidth_rule, tail_eps, samples_per_voxel, downsample,
/// bounds, full_res_min_spacing, gmm_components, source and default_tf (where the model holds
/// one). hasQuantiles, hasGmm: whether the file holds those arrays.
std::vector<ModelFieldDatum> modelFieldData(const ModelVolume& model, bool hasQuantiles,
                                            bool hasGmm);

}  // namespace udvr
