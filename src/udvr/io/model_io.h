#pragma once
// Model volumes as VTK XML ImageData (SPEC §7): point arrays mean, stddev, min, max,
// quantiles (q+1 comps), iqr (2), gmm (3K) and the field data listed in SPEC §7.
#include <filesystem>

#include "udvr/io/field_io.h"
#include "udvr/stats/model_volume.h"

namespace udvr {

/// Write atomically; only non-empty arrays are written.
void writeModelVti(const std::filesystem::path& path, const ModelVolume& model);
/// Read a model written by writeModelVti (or any .vti with those array names).
ModelVolume readModelVti(const std::filesystem::path& path);
/// A model .vti (one with a `mean` array) or any scalar field, which becomes a mean-only model
/// (modelFromField); `options` name the field's array/variable and a headerless .raw's layout.
/// What `render` and `probe` read.
ModelVolume readModelOrField(const std::filesystem::path& path,
                             const FieldReadOptions& options = {});

}  // namespace udvr
