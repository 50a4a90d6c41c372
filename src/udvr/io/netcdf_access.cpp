// Safe access to netCDF-C and HDF5 (netcdf_access.h).
#include "udvr/io/netcdf_access.h"

#include <fcntl.h>
#include <hdf5.h>
#ifdef UDVR_FUZZ_LIBFUZZER
#include <sanitizer/common_interface_defs.h>
#endif
#include <netcdf.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <iomanip>
#include <limits>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "udvr/io/ensemble_io.h"
#include "udvr/io/field_io.h"
#include "udvr/io/io_detail.h"
#include "udvr/util/atomic_file.h"
#include "udvr/util/check.h"

// Safe access to netCDF-C and HDF5 (netcdf_access.h).
#include <fcntl.h>
#include <hdf5.h>

#include "udvr/io/netcdf_access.h"
#ifdef UDVR_FUZZ_LIBFUZZER
#include <sanitizer/common_interface_defs.h>
#endif
#include <netcdf.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <iomanip>
#include <limits>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "udvr/io/ensemble_io.h"
#include "udvr/io/field_io.h"
#include "udvr/io/io_detail.h"
#include "udvr/util/atomic_file.h"
#include "udvr/util/check.h"

namespace udvr::netcdf {

std::recursive_mutex& netcdfLibraryMutex() {
    static std::recursive_mutex mutex;
    return mutex;
}
bool gInProbeChild = false;
thread_local int tNetcdfLockDepth = 0;

namespace {
constexpr const char* kLockContract =
    "a netCDF-C call without netcdfLibraryMutex (the contract of netcdf_access.h)";
}  // namespace

/// netCDF-C says only "NetCDF: HDF error" when HDF5 cannot read a NetCDF-4 file; that is how a
/// truncated or damaged one fails, so say so.
std::string ncErrorText(int status) {
    if (status == NC_EHDFERR)
        return std::string("cannot read NetCDF-4/HDF5 data (the file is truncated or damaged: ") +
               nc_strerror(status) + ")";
    return nc_strerror(status);
}

void ncCheck(int status, const fs::path& path, const std::string& what) {
    UDVR_CHECK_MSG(netcdfLockHeld(), kLockContract);
    if (status != NC_NOERR) {
        UDVR_FAIL(path.string() << ": " << what << ": " << ncErrorText(status));
    }
}

/// For the writer: a FileError "cannot write PATH: what: reason" (a positive status is errno).
void ncWriteCheck(int status, const fs::path& path, const std::string& what) {
    UDVR_CHECK_MSG(netcdfLockHeld(), kLockContract);
    if (status != NC_NOERR) {
        UDVR_FILE_FAIL("cannot write "
                       << path.string() << ": " << what << ": "
                       << (status > 0 ? writeErrorText(status) : std::string(nc_strerror(status))));
    }
}

/// A NetCDF-4 file is HDF5, whose superblock (at offset 0, as netCDF-C writes it) records the
/// end-of-file address; a file shorter than that was cut (HDF5 itself says only "HDF error").
/// Superblock versions 0/1: base address after 24/28 bytes, then free-space, end-of-file;
/// versions 2/3: base, superblock extension, end-of-file after 12 bytes (HDF5 File Format
/// Specification, section II.A). Addresses are little-endian, 2..8 bytes wide.
/// Returns whether the file is HDF5.
bool checkHdf5Size(const fs::path& path) {
    unsigned char b[64] = {};
    std::ifstream in(path, std::ios::binary);
    in.read(reinterpret_cast<char*>(b), sizeof b);
    const std::size_t got = static_cast<std::size_t>(in.gcount());
    static const unsigned char kSignature[8] = {0x89, 'H', 'D', 'F', '\r', '\n', 0x1a, '\n'};
    if (got < 8 || std::memcmp(b, kSignature, 8) != 0) return false;
    const std::size_t fileSize = static_cast<std::size_t>(fs::file_size(path));
    const int version = got > 8 ? b[8] : -1;
    std::size_t offsets = 0, base = 0;
    if (version == 0 || version == 1) {
        offsets = got > 13 ? b[13] : 0;
        base = version == 0 ? 24 : 28;
    } else if (version == 2 || version == 3) {
        offsets = got > 9 ? b[9] : 0;
        base = 12;
    } else if (got > 8) {
        return true;  // a superblock version this check does not know: netCDF-C decides
    }
    const std::size_t eofAt = base + 2 * offsets;
    if (offsets < 2 || offsets > 8 || eofAt + offsets > got) {
        UDVR_FAIL(path.string() << ": cannot read NetCDF-4/HDF5 data (the file is truncated or "
                                   "damaged: no complete HDF5 superblock in its "
                                << fileSize << " bytes)");
    }
    auto address = [&](std::size_t at) {
        std::uint64_t v = 0;
        for (std::size_t i = offsets; i-- > 0;) v = (v << 8) | b[at + i];
        return v;
    };
    const std::uint64_t undefined = offsets == 8 ? ~0ull : (1ull << (8 * offsets)) - 1;
    const std::uint64_t baseAddress = address(base), eof = address(eofAt);
    if (baseAddress == undefined || eof == undefined) return true;
    if (baseAddress + eof > fileSize) {
        UDVR_FAIL(path.string() << ": truncated NetCDF-4/HDF5 file: expected " << baseAddress + eof
                                << " bytes, found " << fileSize);
    }
    return true;
}

/// The netCDF-C calls a read of the file makes, on every variable of the root group: its
/// metadata (for NetCDF-4, HDF5 reads dimension scales and attributes lazily here), its
/// attributes, and its data (whole when it has at most 2^24 values, else its first and last
/// value). Returns when they are done, whatever they returned.
void walkNetcdf(const char* path) {
    int nc = -1;
    if (nc_open(path, NC_NOWRITE, &nc) != NC_NOERR) return;
    int nvars = 0;
    nc_inq_nvars(nc, &nvars);
    for (int v = 0; v < nvars; ++v) {
        char name[NC_MAX_NAME + 1];
        nc_type type = 0;
        int ndims = 0, natts = 0;
        int dims[NC_MAX_VAR_DIMS];
        if (nc_inq_var(nc, v, name, &type, &ndims, dims, &natts) != NC_NOERR) continue;
        std::vector<std::size_t> lengths(static_cast<std::size_t>(std::max(ndims, 0)));
        double values = 1;
        for (int d = 0; d < ndims; ++d) {
            if (nc_inq_dim(nc, dims[d], name, &lengths[static_cast<std::size_t>(d)]) != NC_NOERR)
                lengths[static_cast<std::size_t>(d)] = 0;
            values *= static_cast<double>(lengths[static_cast<std::size_t>(d)]);
        }
        for (int a = 0; a < natts; ++a) {
            std::size_t len = 0;
            nc_type atype = 0;
            if (nc_inq_attname(nc, v, a, name) != NC_NOERR ||
                nc_inq_att(nc, v, name, &atype, &len) != NC_NOERR || len > (1u << 24))
                continue;
            if (atype == NC_STRING) {
                std::vector<char*> strings(len);
                if (nc_get_att_string(nc, v, name, strings.data()) == NC_NOERR)
                    nc_free_string(len, strings.data());
            } else if (atype == NC_CHAR) {
                std::vector<char> text(len + 1);
                nc_get_att_text(nc, v, name, text.data());
            } else {
                std::vector<double> buffer(len + 1);
                nc_get_att_double(nc, v, name, buffer.data());
            }
        }
        if (type == NC_CHAR || type == NC_STRING || type > NC_STRING || values < 1) continue;
        if (values <= static_cast<double>(1u << 24)) {
            std::vector<double> buffer(static_cast<std::size_t>(values));
            nc_get_var_double(nc, v, buffer.data());
        } else {
            std::vector<std::size_t> at(lengths.size(), 0), one(lengths.size(), 1);
            double value = 0;
            nc_get_vara_double(nc, v, at.data(), one.data(), &value);
            for (std::size_t d = 0; d < at.size(); ++d) at[d] = lengths[d] - 1;
            nc_get_vara_double(nc, v, at.data(), one.data(), &value);
        }
    }
    nc_close(nc);
}

/// The probe's time limit for a file of 0 bytes (setHdf5ProbeSeconds).
std::atomic<double> gHdf5ProbeSeconds{10.0};

/// NetCDF-4 files are HDF5 files, and HDF5 1.10.8 (Debian 12) crashes or loops forever on some
/// damaged ones (found by fuzzing, docs/testing.md: a corrupt global heap read for a dimension
/// list never ends). Before udvr reads one, a child process does `childWork` (the calls of
/// walkNetcdf, or the very read that follows: guardedRead); the read goes ahead once the child
/// has finished (netCDF errors included: the read reports those itself). A child killed by a
/// signal, or not done within 10 s (setHdf5ProbeSeconds) plus 1 s per 4 MB of file, becomes a
/// one-line error. `kind` names the work, for the cache below.
void probeHdf5(const fs::path& path, const std::string& kind,
               const std::function<void()>& childWork) {
    // A read opens a file more than once (`udvr info`, then the field): the last file probed,
    // unchanged since, and its outcome are remembered. File times are coarse (a few ms), so
    // "unchanged" also compares a hash of the first and last 64 KB (all of a small file).
    struct Probed {
        std::string path, kind, error;
        std::uintmax_t size = 0;
        std::int64_t mtime = 0, ctime = 0, inode = 0;
        std::size_t hash = 0;
        bool operator==(const Probed& o) const {
            return path == o.path && kind == o.kind && size == o.size && mtime == o.mtime &&
                   ctime == o.ctime && inode == o.inode && hash == o.hash;
        }
    };
    static Probed last;
    static std::mutex lastMutex;
    struct stat st {};
    if (stat(path.c_str(), &st) != 0) return;
    const auto nanoseconds = [](const timespec& t) {
        return static_cast<std::int64_t>(t.tv_sec) * 1000000000 + t.tv_nsec;
    };
    std::string ends(std::min<std::uintmax_t>(static_cast<std::uintmax_t>(st.st_size), 1 << 17),
                     '\0');
    {
        std::ifstream in(path, std::ios::binary);
        const std::size_t half = ends.size() / 2;
        in.read(ends.data(), static_cast<std::streamsize>(half));
        in.seekg(-static_cast<std::streamoff>(ends.size() - half), std::ios::end);
        in.read(ends.data() + half, static_cast<std::streamsize>(ends.size() - half));
    }
    const Probed now{path.string(),
                     kind,
                     "",
                     static_cast<std::uintmax_t>(st.st_size),
                     nanoseconds(st.st_mtim),
                     nanoseconds(st.st_ctim),
                     static_cast<std::int64_t>(st.st_ino),
                     std::hash<std::string>{}(ends)};
    {
        std::lock_guard<std::mutex> lock(lastMutex);
        if (last == now) {
            if (!last.error.empty()) UDVR_FAIL(last.error);
            return;
        }
    }
    const auto remember = [&](const std::string& error) {
        std::lock_guard<std::mutex> lock(lastMutex);
        last = now;
        last.error = error;
        if (!error.empty()) UDVR_FAIL(error);
    };
    const double limit = gHdf5ProbeSeconds.load() + static_cast<double>(now.size) / (4 << 20);
    const NetcdfLock lock(netcdfLibraryMutex());  // held across fork (see netcdfLibraryMutex)
    std::fflush(nullptr);
    const pid_t child = fork();
    if (child < 0) return;  // no process to spare: read without the probe
    if (child == 0) {
        gInProbeChild = true;
        // The child: quiet (HDF5 may print its error stack) and gone without exit handlers.
        const int devnull = open("/dev/null", O_WRONLY);
        if (devnull >= 0) {
            dup2(devnull, 1);
            dup2(devnull, 2);
        }
#ifdef UDVR_FUZZ_LIBFUZZER
        // Under libFuzzer a sanitizer report here would save the input as the fuzzer's own
        // crash; the child just dies (exit 1), which the parent reports as a crash.
        __sanitizer_set_death_callback(nullptr);
#endif
        try {
            childWork();
        } catch (...) {  // the read reports its errors itself
        }
        _exit(0);
    }
    const auto start = std::chrono::steady_clock::now();
    int status = 0;
    auto pause = std::chrono::microseconds(50);
    for (;;) {
        const pid_t done = waitpid(child, &status, WNOHANG);
        if (done == child) break;
        if (done < 0 && errno != EINTR) return;  // the child is not ours to wait for
        if (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() >
            limit) {
            kill(child, SIGKILL);
            waitpid(child, &status, 0);
            std::ostringstream error;
            error << path.string() << ": the HDF5 library did not finish reading this NetCDF-4 "
                  << "file within ";
            if (limit >= 10)
                error << std::lround(limit);
            else
                error << std::setprecision(2) << limit;
            error << " s (a damaged file?)";
            remember(error.str());
        }
        std::this_thread::sleep_for(pause);
        pause = std::min(pause * 2, decltype(pause)(std::chrono::milliseconds(20)));
    }
    std::string error;
    if (WIFSIGNALED(status))
        error = path.string() + ": the HDF5 library crashed reading this NetCDF-4 file (signal " +
                std::to_string(WTERMSIG(status)) + "; a damaged file?)";
    else if (WIFEXITED(status) && WEXITSTATUS(status) != 0)  // the child ends with _exit(0)
        error = path.string() + ": the HDF5 library failed reading this NetCDF-4 file (exit " +
                std::to_string(WEXITSTATUS(status)) + "; a damaged file?)";
    remember(error);
}

/// netCDF-C reads the data of a cut classic-format file as zeros, without an error, so compare
/// where the header says the data end with the file size (CDF-1, CDF-2 and CDF-5 layouts).
/// Runs before nc_open: netCDF-C allocates what the header's counts ask for (a variable of 2^31
/// dimensions, found by fuzzing), so every count must fit in what is left of the file.
void checkClassicSize(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::size_t fileSize = static_cast<std::size_t>(fs::file_size(path));
    auto fail = [&]() {
        UDVR_FAIL(path.string() << ": truncated NetCDF header (file of " << fileSize << " bytes)");
    };
    auto be = [&](std::size_t n) {
        unsigned char b[8];
        if (!in.read(reinterpret_cast<char*>(b), static_cast<std::streamsize>(n))) fail();
        std::uint64_t v = 0;
        for (std::size_t i = 0; i < n; ++i) v = (v << 8) | b[i];
        return v;
    };
    char magic[4];
    if (!in.read(magic, 4) || magic[0] != 'C' || magic[1] != 'D' || magic[2] != 'F') return;
    int version = magic[3];
    if (version != 1 && version != 2 && version != 5) return;  // netCDF-C rejects it
    std::size_t countSize = version == 5 ? 8 : 4;              // nelems, dim lengths, vsize
    std::size_t offsetSize = version == 1 ? 4 : 8;             // begin
    auto skip = [&](std::uint64_t n) {
        if (n > fileSize) fail();
        in.seekg(static_cast<std::streamoff>(n), std::ios::cur);
    };
    // `n` bytes padded to 4, after checking n against the file (no overflow of the padding).
    auto skipPadded = [&](std::uint64_t n) {
        if (n > fileSize) fail();
        skip((n + 3) / 4 * 4);
    };
    auto skipName = [&]() { skipPadded(be(countSize)); };
    // A count of entries of at least `entryBytes` bytes each, no more than the file can hold.
    auto countOf = [&](std::uint64_t entryBytes) {
        const std::uint64_t n = be(countSize);
        if (n > fileSize / entryBytes) fail();
        return n;
    };
    // A type code netCDF-C knows (NC_BYTE … NC_DOUBLE; CDF-5 also NC_UBYTE … NC_UINT64): for
    // another, netCDF-C 4.9.0 divides by its size of 0 (SIGFPE in NC_check_vlen, found by
    // fuzzing).
    auto ncType = [&](std::uint64_t t) {
        if (t < NC_BYTE || t > static_cast<std::uint64_t>(version == 5 ? NC_UINT64 : NC_DOUBLE))
            UDVR_FAIL(path.string()
                      << ": NetCDF header: type code " << t << " is not a NetCDF type");
        return t;
    };
    // Products of dimension lengths that overflow are "more than any file": the check fails.
    auto saturatingProduct = [](std::uint64_t a, std::uint64_t b) {
        return b != 0 && a > ~0ull / b ? ~0ull : a * b;
    };
    auto typeSize = [](std::uint64_t t) -> std::uint64_t {
        switch (t) {
            case NC_BYTE:
            case NC_CHAR:
            case NC_UBYTE:
                return 1;
            case NC_SHORT:
            case NC_USHORT:
                return 2;
            case NC_INT:
            case NC_UINT:
            case NC_FLOAT:
                return 4;
            default:
                return 8;
        }
    };
    auto skipAttributes = [&]() {
        be(4);  // NC_ATTRIBUTE or ABSENT
        std::uint64_t n = countOf(2 * countSize + 4);
        for (std::uint64_t a = 0; a < n; ++a) {
            skipName();
            std::uint64_t type = ncType(be(4));
            const std::uint64_t values = be(countSize);
            if (values > fileSize) fail();
            skipPadded(values * typeSize(type));
        }
    };
    std::uint64_t numrecs = be(countSize);
    // Streaming: the record count is unknown; the header is checked all the same.
    const bool streaming = numrecs == (version == 5 ? ~0ull : 0xffffffffull);
    be(4);  // NC_DIMENSION or ABSENT
    std::vector<std::uint64_t> dimLengths(countOf(2 * countSize));
    for (auto& len : dimLengths) {
        skipName();
        len = be(countSize);
    }
    skipAttributes();
    be(4);  // NC_VARIABLE or ABSENT
    std::uint64_t nvars = countOf(4 * countSize + 8);
    struct Var {
        bool record;
        std::uint64_t bytes, begin;
    };
    std::vector<Var> vars;
    std::uint64_t recordSize = 0;
    for (std::uint64_t v = 0; v < nvars; ++v) {
        skipName();
        std::uint64_t ndims = countOf(countSize);
        bool record = false;
        std::uint64_t count = 1;
        for (std::uint64_t d = 0; d < ndims; ++d) {
            std::uint64_t id = be(countSize);
            if (id >= dimLengths.size()) fail();
            if (d == 0 && dimLengths[id] == 0) {
                record = true;
            } else {
                count = saturatingProduct(count, dimLengths[id]);
            }
        }
        skipAttributes();
        std::uint64_t bytes = saturatingProduct(count, typeSize(ncType(be(4))));
        std::uint64_t vsize = be(countSize);
        std::uint64_t begin = be(offsetSize);
        if (record) recordSize = recordSize > ~0ull - vsize ? ~0ull : recordSize + vsize;
        vars.push_back({record, bytes, begin});
    }
    // In long double: header values near 2^64 must not wrap around to a small end.
    long double needed = 0;
    std::size_t recordVars = static_cast<std::size_t>(
        std::count_if(vars.begin(), vars.end(), [](const Var& v) { return v.record; }));
    for (const Var& v : vars) {
        long double end = static_cast<long double>(v.begin) + static_cast<long double>(v.bytes);
        if (v.record) {
            if (numrecs == 0 || streaming) continue;
            // A lone record variable is not padded per record.
            const long double stride =
                static_cast<long double>(recordVars == 1 ? v.bytes : recordSize);
            end += static_cast<long double>(numrecs - 1) * stride;
        }
        needed = std::max(needed, end);
    }
    if (needed > static_cast<long double>(fileSize)) {
        std::ostringstream expected;
        if (needed < 9.2e18L)
            expected << static_cast<std::uint64_t>(needed);
        else
            expected << static_cast<double>(needed);
        UDVR_FAIL(path.string() << ": truncated NetCDF data: expected " << expected.str()
                                << " bytes, found " << fileSize);
    }
}

/// netCDF-C 4.9.0 leaves a damaged NetCDF-4 file open in HDF5 when nc_open fails on it, and
/// HDF5 then serves the next open of that file (or of another at the same inode) from the cached
/// damaged metadata: `udvr info` followed by a read crashed in H5HG_read with a memcpy of 2^63
/// bytes (found by fuzzing). Closes every HDF5 object still open. Called only while udvr has no
/// NetCDF file open (reads are serial, one file at a time, closed by NcFile on scope exit).
void releaseLeftoverHdf5Objects() {
    H5E_BEGIN_TRY {
        const ssize_t count = H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_ALL);
        if (count > 0) {
            std::vector<hid_t> ids(static_cast<std::size_t>(count));
            const ssize_t got = H5Fget_obj_ids(H5F_OBJ_ALL, H5F_OBJ_ALL, ids.size(), ids.data());
            for (ssize_t i = 0; i < got; ++i) {
                while (H5Iis_valid(ids[static_cast<std::size_t>(i)]) > 0 &&
                       H5Idec_ref(ids[static_cast<std::size_t>(i)]) > 0) {
                }
            }
        }
    }
    H5E_END_TRY;
}

/// The file whose whole read runs under guardedRead on this thread: its probe was that read.
thread_local const fs::path* tGuardedPath = nullptr;

int openForRead(const fs::path& path) {
    UDVR_CHECK_MSG(netcdfLockHeld(), kLockContract);
    detail::requireFile(path);
    releaseLeftoverHdf5Objects();
    const bool hdf5 = checkHdf5Size(path);
    if (hdf5 && (tGuardedPath == nullptr || *tGuardedPath != path))
        probeHdf5(path, "walk", [&] { walkNetcdf(path.c_str()); });
    checkClassicSize(path);
    int nc = -1;
    int status = nc_open(path.c_str(), NC_NOWRITE, &nc);
    if (status != NC_NOERR) {
        releaseLeftoverHdf5Objects();
        if (status == NC_EHDFERR) UDVR_FAIL(path.string() << ": " << ncErrorText(status));
        UDVR_FAIL(path.string() << ": cannot open as NetCDF: " << nc_strerror(status));
    }
    return nc;
}

}  // namespace udvr::netcdf

namespace udvr {
void detail::setHdf5ProbeSeconds(double seconds) { netcdf::gHdf5ProbeSeconds = seconds; }
}  // namespace udvr
