#pragma once
// Write-then-rename: outputs appear whole or not at all (SPEC §8).
#include <filesystem>
#include <functional>
#include <string>

namespace udvr {

/// Call write(tmpPath) with a temporary path beside `path`, then rename it onto `path`.
/// If write throws, the temporary file is removed and the exception propagates.
/// The temporary keeps the final extension (VTK and NetCDF writers look at it).
void writeAtomically(const std::filesystem::path& path,
                     const std::function<void(const std::filesystem::path& tmpPath)>& write);

/// Write bytes to `path` atomically.
void writeFileAtomically(const std::filesystem::path& path, const std::string& bytes);

}  // namespace udvr
