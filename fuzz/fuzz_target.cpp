// Shared parts of the fuzz targets (fuzz_target.h).
#include "fuzz_target.h"

#include <fcntl.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <iterator>
#include <typeinfo>

#include "udvr/util/check.h"

namespace udvr::fuzz {
namespace fs = std::filesystem;

#ifdef UDVR_FUZZ_LIBFUZZER
extern "C" void __sanitizer_set_report_fd(void* fd);
#endif

namespace {
std::vector<std::pair<std::string, TargetFn>>& registry() {
    static std::vector<std::pair<std::string, TargetFn>> r;
    return r;
}

/// The process's stderr, kept while fd 2 is redirected: findings and sanitizer reports go here.
int realStderr() {
    static const int fd = [] {
        const int d = fcntl(2, F_DUPFD_CLOEXEC, 3);
#ifdef UDVR_FUZZ_LIBFUZZER
        __sanitizer_set_report_fd(reinterpret_cast<void*>(static_cast<std::intptr_t>(d)));
#endif
        return d;
    }();
    return fd;
}

void writeRealStderr(const std::string& text) {
    const std::string line = text + "\n";
    if (write(realStderr(), line.data(), line.size()) < 0) std::abort();
}

/// Redirects fd 2 to a scratch file while it lives; text() is what was written.
class CapturedStderr {
  public:
    CapturedStderr() : path_(Scratch::get().path(".stderr")) {
        realStderr();
        std::fflush(stderr);
        const int fd = open(path_.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
        if (fd < 0 || dup2(fd, 2) < 0) std::abort();
        close(fd);
    }
    ~CapturedStderr() { restore(); }
    std::string text() {
        restore();
        std::ifstream in(path_, std::ios::binary);
        return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    }

  private:
    void restore() {
        if (restored_) return;
        restored_ = true;
        std::fflush(stderr);
        if (dup2(realStderr(), 2) < 0) std::abort();
    }
    fs::path path_;
    bool restored_ = false;
};
}  // namespace

bool registerTarget(const char* name, TargetFn fn) {
    registry().emplace_back(name, fn);
    return true;
}

const std::vector<std::pair<std::string, TargetFn>>& targets() { return registry(); }

void finding(const std::string& what) {
#ifdef UDVR_FUZZ_LIBFUZZER
    writeRealStderr("udvr fuzz finding: " + what);
    std::abort();
#else
    throw Finding{what};
#endif
}

std::vector<std::string> splitParts(Input in, std::size_t maxParts) {
    const std::string all = text(in);
    std::vector<std::string> parts;
    std::size_t pos = 0;
    while (parts.size() + 1 < maxParts) {
        const std::size_t next = all.find(kPartSeparator, pos);
        if (next == std::string::npos) break;
        parts.push_back(all.substr(pos, next - pos));
        pos = next + kPartSeparator.size();
    }
    parts.push_back(all.substr(pos));
    return parts;
}

Scratch& Scratch::get() {
    static Scratch s;
    return s;
}

Scratch::Scratch() {
    std::string tmpl = (fs::temp_directory_path() / "udvr_fuzz_XXXXXX").string();
    if (mkdtemp(tmpl.data()) == nullptr) {
        std::perror("udvr fuzz: mkdtemp");
        std::abort();
    }
    dir_ = tmpl;
}

Scratch::~Scratch() {
    std::error_code ec;
    fs::remove_all(dir_, ec);
}

void Scratch::clear() {
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir_, ec)) fs::remove_all(e.path(), ec);
}

fs::path Scratch::write(const std::string& name, std::string_view bytes) {
    const fs::path p = dir_ / name;
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!out) finding("cannot write the scratch file " + p.string());
    return p;
}

void checkMessage(const std::string& m) {
    if (m.empty()) finding("empty error message");
    std::size_t i = 0;
    while (i < m.size()) {
        const auto c = static_cast<unsigned char>(m[i]);
        if (c < 0x20 || c == 0x7F)
            finding("control character " + std::to_string(c) + " in error message: " + m);
        if (c < 0x80) {
            ++i;
            continue;
        }
        // A UTF-8 sequence: its length, the range of its code point (no overlongs, no
        // surrogates, at most U+10FFFF) and no C1 control characters.
        std::size_t len = 0;
        std::uint32_t cp = 0, min = 0;
        if ((c & 0xE0) == 0xC0) {
            len = 2;
            cp = c & 0x1F;
            min = 0x80;
        } else if ((c & 0xF0) == 0xE0) {
            len = 3;
            cp = c & 0x0F;
            min = 0x800;
        } else if ((c & 0xF8) == 0xF0) {
            len = 4;
            cp = c & 0x07;
            min = 0x10000;
        } else {
            finding("invalid UTF-8 in error message: " + m);
        }
        if (i + len > m.size()) finding("truncated UTF-8 in error message: " + m);
        for (std::size_t k = 1; k < len; ++k) {
            const auto cc = static_cast<unsigned char>(m[i + k]);
            if ((cc & 0xC0) != 0x80) finding("invalid UTF-8 in error message: " + m);
            cp = (cp << 6) | (cc & 0x3F);
        }
        if (cp < min || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF) ||
            (cp >= 0x80 && cp <= 0x9F))
            finding("invalid UTF-8 in error message: " + m);
        i += len;
    }
}

bool expectCleanResult(const std::function<void()>& read) {
    CapturedStderr captured;
    try {
        read();
        return true;  // notes on stderr are fine after a successful read
    } catch (const Finding&) {
        throw;
    } catch (const UdvrError& e) {
        static const bool verbose = std::getenv("UDVR_FUZZ_VERBOSE") != nullptr;
        if (verbose) writeRealStderr(std::string("udvr fuzz: reader error: ") + e.what());
        checkMessage(e.what());
        const std::string printed = captured.text();
        if (!printed.empty())
            finding("the reader printed on stderr before its error (" + std::string(e.what()) +
                    "): " + printed);
    } catch (const std::exception& e) {
        finding(std::string("exception other than UdvrError (") + typeid(e).name() +
                "): " + e.what());
    } catch (...) {
        finding("exception of an unknown type");
    }
    return false;
}

}  // namespace udvr::fuzz
