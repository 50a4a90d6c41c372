#pragma once
// Write-then-rename: outputs appear whole or not at all (SPEC §8; docs/formats.md, "Output
// files"). The temporary file sits beside the destination as `.STEM.tmpPID.EXT`: hidden,
// recognisable, on the same file system (so the rename is atomic), named after its writer.
#include <filesystem>
#include <functional>
#include <string>

namespace udvr {

/// Call write(tmpPath) with a temporary path beside `path`, then rename it onto `path`.
/// If write throws, the temporary file is removed and the exception propagates.
/// The temporary keeps the final extension (VTK and NetCDF writers look at it).
/// Before writing: the directory must exist and be writable (FileError otherwise), and stale
/// temporaries of the same destination whose process no longer runs (left by kill -9) are
/// removed. While write runs, the temporary is registered for removal by the CLI's SIGINT,
/// SIGTERM and SIGHUP handler (installInterruptCleanup).
void writeAtomically(const std::filesystem::path& path,
                     const std::function<void(const std::filesystem::path& tmpPath)>& write);

/// Write bytes to `path` atomically.
void writeFileAtomically(const std::filesystem::path& path, const std::string& bytes);

/// The temporary path writeAtomically uses for `path` in process `pid`.
std::filesystem::path temporaryPathFor(const std::filesystem::path& path, long pid);

/// Throws FileError "cannot write PATH: directory DIR …" unless the directory `path` goes into
/// exists and this process may create files in it (access(2); a read-only mount fails too).
void requireWritableDirectory(const std::filesystem::path& path);

/// Why a write failed, from errno (`err` > 0): strerror's text, with a hint for a full disk and
/// the file size limit. Empty for err ≤ 0.
std::string writeErrorText(int err);

/// For the CLI's main(): SIGINT, SIGTERM and SIGHUP remove the temporaries being written, then
/// terminate the process as the signal would have; SIGXFSZ is ignored, so a write over the file
/// size limit (ulimit -f) fails with EFBIG and is reported like a full disk instead of killing
/// the process. Not for the Python module (Python owns its signals).
void installInterruptCleanup();

}  // namespace udvr
