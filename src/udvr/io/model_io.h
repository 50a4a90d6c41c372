#pragma once
// Model volumes as VTK XML ImageData (SPEC §7): point arrays mean, stddev, min, max,
// quantiles (q+1 comps), iqr (2), gmm (3K) and the field data listed in SPEC §7.
#include <filesystem>

#include "udvr/stats/model_volume.h"

namespace udvr {

/// Write atomically; only non-empty arrays are written.
void writeModelVti(const std::filesystem::path& path, const ModelVolume& model);
/// Read a model written by writeModelVti (or any .vti with those array names).
ModelVolume readModelVti(const std::filesystem::path& path);

}  // namespace udvr
