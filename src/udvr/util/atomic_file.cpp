#include "udvr/util/atomic_file.h"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <fstream>
#include <system_error>

#include "udvr/util/check.h"

namespace udvr {
namespace {

namespace fs = std::filesystem;

// The temporaries being written, for the signal handler: it may only read memory that is
// already there (no allocation, no locks), so a fixed table of fixed-size paths. This is the one
// piece of mutable global state here; a signal handler has no other way to know them. A path
// that does not fit, or a 17th concurrent write, is simply not registered (kill -9 leaves such
// files too; the next write of the same destination removes them).
constexpr int kTempSlots = 16;
constexpr std::size_t kTempPathBytes = 4096;
struct TempSlot {
    std::atomic<int> state{0};  // 0 free, 1 being filled or emptied, 2 holds a path
    char path[kTempPathBytes] = {};
};
TempSlot gTempSlots[kTempSlots];

int registerTemp(const fs::path& tmp) {
    const std::string& s = tmp.native();
    if (s.size() >= kTempPathBytes) return -1;
    for (int i = 0; i < kTempSlots; ++i) {
        int expected = 0;
        if (gTempSlots[i].state.compare_exchange_strong(expected, 1)) {
            std::memcpy(gTempSlots[i].path, s.c_str(), s.size() + 1);
            gTempSlots[i].state.store(2);
            return i;
        }
    }
    return -1;
}

void unregisterTemp(int slot) {
    if (slot < 0) return;
    gTempSlots[slot].state.store(1);
    gTempSlots[slot].path[0] = '\0';
    gTempSlots[slot].state.store(0);
}

extern "C" void removeTempsAndReraise(int sig) {
    const int savedErrno = errno;
    for (TempSlot& slot : gTempSlots)
        if (slot.state.load() == 2) ::unlink(slot.path);  // async-signal-safe
    errno = savedErrno;
    std::signal(sig, SIG_DFL);
    std::raise(sig);  // terminate as the signal would have (exit status 128 + sig in a shell)
}

/// `name` is `.STEM.tmpPID.EXT` of `path` for some PID: returns the PID, else -1.
long temporaryPid(const std::string& name, const fs::path& path) {
    const std::string prefix = "." + path.stem().string() + ".tmp";
    const std::string suffix = path.extension().string();
    if (name.size() <= prefix.size() + suffix.size() ||
        name.compare(0, prefix.size(), prefix) != 0 ||
        name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0)
        return -1;
    const std::string digits =
        name.substr(prefix.size(), name.size() - prefix.size() - suffix.size());
    if (digits.empty() || digits.size() > 9 ||
        digits.find_first_not_of("0123456789") != std::string::npos)
        return -1;
    return std::stol(digits);
}

/// Remove the temporaries of `path` left by processes that no longer run (SIGKILL, power loss).
/// kill(pid, 0) fails with ESRCH only for a PID no process has on this machine; a PID reused
/// by an unrelated process keeps its file (harmless, and removed once that PID is free again).
void removeStaleTemporaries(const fs::path& path) {
    const fs::path dir = path.parent_path().empty() ? fs::path(".") : path.parent_path();
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        const long pid = temporaryPid(it->path().filename().string(), path);
        if (pid <= 0 || pid == static_cast<long>(getpid())) continue;
        if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;
        std::error_code removeError;  // another process may remove it first
        fs::remove(it->path(), removeError);
    }
}

}  // namespace

fs::path temporaryPathFor(const fs::path& path, long pid) {
    fs::path tmp = path;
    tmp.replace_filename("." + path.stem().string() + ".tmp" + std::to_string(pid) +
                         path.extension().string());
    return tmp;
}

std::string writeErrorText(int err) {
    if (err <= 0) return {};
    std::string text = std::strerror(err);
    if (err == ENOSPC) text += " (the disk is full)";
    if (err == EFBIG) text += " (over the file size limit, ulimit -f)";
    if (err == EDQUOT) text += " (over the disk quota)";
    return text;
}

void requireWritableDirectory(const fs::path& path) {
    const fs::path dir = path.parent_path();
    const fs::path shown = dir.empty() ? fs::path(".") : dir;
    std::error_code ec;
    if (!fs::is_directory(shown, ec)) {
        UDVR_FILE_FAIL("cannot write " << path.string() << ": directory " << shown.string()
                                       << " does not exist");
    }
    // W_OK for creating the temporary, X_OK for reaching it; EROFS for a read-only mount.
    if (::access(shown.c_str(), W_OK | X_OK) != 0) {
        const int err = errno;
        UDVR_FILE_FAIL("cannot write " << path.string() << ": directory " << shown.string()
                                       << " is not writable (" << writeErrorText(err) << ")");
    }
}

void writeAtomically(const fs::path& path,
                     const std::function<void(const fs::path& tmpPath)>& write) {
    requireWritableDirectory(path);
    removeStaleTemporaries(path);
    const fs::path tmp = temporaryPathFor(path, static_cast<long>(getpid()));
    const int slot = registerTemp(tmp);
    try {
        write(tmp);
    } catch (...) {
        std::error_code ec;
        fs::remove(tmp, ec);
        unregisterTemp(slot);
        throw;
    }
    std::error_code ec;
    fs::rename(tmp, path, ec);
    if (ec) {
        const std::string why = fs::is_directory(path) ? "it is a directory" : ec.message();
        std::error_code removeError;  // ec holds the reason; do not overwrite it
        fs::remove(tmp, removeError);
        unregisterTemp(slot);
        UDVR_FILE_FAIL("cannot write " << path.string() << ": " << why);
    }
    unregisterTemp(slot);
}

void writeFileAtomically(const fs::path& path, const std::string& bytes) {
    writeAtomically(path, [&](const fs::path& tmp) {
        errno = 0;
        std::ofstream out(tmp, std::ios::binary);
        if (!out) UDVR_FILE_FAIL("cannot write " << path.string() << ": " << writeErrorText(errno));
        out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
        out.flush();
        int err = errno;
        out.close();  // the last buffer is written here: its error counts too
        if (err == 0) err = errno;
        if (!out) {
            UDVR_FILE_FAIL("cannot write " << path.string() << ": "
                                           << (err > 0 ? writeErrorText(err) : "write failed"));
        }
    });
}

void installInterruptCleanup() {
    struct sigaction sa {};
    sa.sa_handler = removeTempsAndReraise;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESETHAND;
    for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
        struct sigaction old {};
        // A signal ignored by the parent (nohup, a shell's background job) stays ignored.
        if (::sigaction(sig, nullptr, &old) == 0 && old.sa_handler == SIG_IGN) continue;
        ::sigaction(sig, &sa, nullptr);
    }
    std::signal(SIGXFSZ, SIG_IGN);
}

}  // namespace udvr
