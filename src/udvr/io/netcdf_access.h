#pragma once
// Safe access to netCDF-C and the HDF5 under it (netcdf_io.cpp reads and writes through it): one
// process-wide lock, errors as one line, size checks before the libraries allocate, and the
// HDF5 probe, a child process that makes a NetCDF-4 read first so that a damaged file on which
// HDF5 crashes or hangs becomes an error (docs/architecture.md, "NetCDF, HDF5 and threads").
// Private to io/.
#include <netcdf.h>

#include <filesystem>
#include <functional>
#include <mutex>
#include <string>

#include "udvr/io/io_detail.h"

namespace udvr::netcdf {
namespace fs = std::filesystem;

/// netCDF-C, and the HDF5 it reads NetCDF-4 through, are not thread-safe, and probeHdf5 forks.
/// The contract: every call into either library in this process holds this lock — the public
/// entry points of this file, each slab read, an NcFile's close — so reads from several threads
/// (Python with the GIL released, `udvr serve`, the slab pipeline of `udvr build`) take turns,
/// and the probe forks while holding it: the child (which has only the forking thread) finds
/// both libraries between calls, never inside one. Recursive: entry points nest.
std::recursive_mutex& netcdfLibraryMutex();
/// True in probeHdf5's child only: the lock it inherited belongs to the parent's thread id, and
/// the child, which has one thread, takes no lock at all.
extern bool gInProbeChild;
/// How many NetcdfLocks this thread holds (netcdfLockHeld).
extern thread_local int tNetcdfLockDepth;
/// Holds netcdfLibraryMutex (none in the probe's child).
class NetcdfLock {
  public:
    explicit NetcdfLock(std::recursive_mutex& mutex) {
        if (!gInProbeChild) lock_ = std::unique_lock<std::recursive_mutex>(mutex);
        ++tNetcdfLockDepth;
    }
    ~NetcdfLock() { --tNetcdfLockDepth; }
    NetcdfLock(const NetcdfLock&) = delete;
    NetcdfLock& operator=(const NetcdfLock&) = delete;

  private:
    std::unique_lock<std::recursive_mutex> lock_;
};
/// Whether this thread may call into netCDF-C/HDF5 now: it holds a NetcdfLock (or is the probe's
/// child, which has one thread). ncCheck, ncWriteCheck and openForRead check it, so a call made
/// without the lock is an internal error rather than a race with the probe's fork().
inline bool netcdfLockHeld() { return gInProbeChild || tNetcdfLockDepth > 0; }

/// Closes the file on scope exit (also when an error unwinds).
struct NcFile {
    int id = -1;
    ~NcFile() {
        const NetcdfLock lock(netcdfLibraryMutex());
        if (id >= 0) nc_close(id);
    }
    int close() {
        const NetcdfLock lock(netcdfLibraryMutex());
        int status = nc_close(id);
        id = -1;
        return status;
    }
};

/// netCDF-C's message for a status; "NetCDF: HDF error" explained as a truncated or damaged file.
std::string ncErrorText(int status);
/// Throws "PATH: what: reason" unless status is NC_NOERR.
void ncCheck(int status, const fs::path& path, const std::string& what);
/// For the writer: a FileError "cannot write PATH: what: reason" (a positive status is errno).
void ncWriteCheck(int status, const fs::path& path, const std::string& what);
/// Whether the file is HDF5 (NetCDF-4); throws when its superblock says it was cut.
bool checkHdf5Size(const fs::path& path);
/// The netCDF-C calls a read of the file makes, on every variable of the root group.
void walkNetcdf(const char* path);
/// childWork in a child process first: a crash, a hang (10 s + 1 s per 4 MB) or a failure there
/// becomes a one-line error here (netcdf_access.cpp says how and why).
void probeHdf5(const fs::path& path, const std::string& kind,
               const std::function<void()>& childWork);
/// A classic-format file's header checked against the file's size before nc_open.
void checkClassicSize(const fs::path& path);
/// Closes every HDF5 object a failed nc_open left open (only while no NetCDF file is open).
void releaseLeftoverHdf5Objects();
/// The file whose whole read runs under guardedRead on this thread: its probe was that read.
extern thread_local const fs::path* tGuardedPath;
/// nc_open for reading after the checks and, for NetCDF-4, the probe.
int openForRead(const fs::path& path);

/// `read()` of a NetCDF-4 file, made first by a child process (probeHdf5) and then here. Both
/// start from the same library state and make the same calls, so a file on which HDF5 crashes or
/// hangs fails in the child and becomes a one-line error here, also where the crash depends on
/// what the library did before (HDF5 reading memory it never wrote: the walk of walkNetcdf,
/// another order of calls, missed two such files; found by fuzzing). Other files: read().
template <typename Read>
auto guardedRead(const fs::path& path, const std::string& kind, Read read) {
    const fs::path* outer = tGuardedPath;
    struct Restore {
        const fs::path* outer;
        ~Restore() { tGuardedPath = outer; }
    } restore{outer};
    if (outer == nullptr) {
        detail::requireFile(path);
        if (checkHdf5Size(path)) {
            releaseLeftoverHdf5Objects();
            probeHdf5(path, kind, [&] {
                tGuardedPath = &path;
                (void)read();
            });
        }
    }
    tGuardedPath = &path;
    return read();
}

}  // namespace udvr::netcdf
