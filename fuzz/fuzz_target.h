#pragma once
// The fuzz targets of udvr's readers (docs/testing.md, "Fuzzing"). Each fuzz/*_fuzz.cpp defines
// one UDVR_FUZZ_TARGET(name) { … } that writes its input to files, calls a reader, and checks
// what comes back: a valid result, or a UdvrError whose message is one non-empty line of valid
// UTF-8 (what the CLI prints). Anything else is a finding: another exception type, a crash, a
// sanitizer report, a malformed message.
//  - Built with UDVR_FUZZ_LIBFUZZER (the Clang build, -DUDVR_FUZZ=ON): the body becomes
//    LLVMFuzzerTestOneInput, one target per binary, and a finding aborts.
//  - Otherwise (the normal build): the body is registered under its name for udvr_fuzz_replay,
//    which ctest runs over the committed corpora, and a finding is an exception it reports.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace udvr::fuzz {

using Input = std::span<const std::uint8_t>;
using TargetFn = void (*)(Input);

/// Registers a target for the replay driver; returns true.
bool registerTarget(const char* name, TargetFn fn);
/// The registered targets (replay driver).
const std::vector<std::pair<std::string, TargetFn>>& targets();

/// Reports a finding: aborts under libFuzzer, throws Finding in the replay driver.
[[noreturn]] void finding(const std::string& what);

/// Thrown by finding() in the replay driver.
struct Finding {
    std::string what;
};

/// The part of the input as text (bytes as they are).
inline std::string text(Input in) {
    return std::string(reinterpret_cast<const char*>(in.data()), in.size());
}

/// Splits the input at each kPartSeparator: several files from one input (a NRRD header and its
/// detached data, ensemble members). The seeds hold the separator; the fuzzer keeps it mostly.
inline constexpr std::string_view kPartSeparator = "\n--udvr-fuzz-next-file--\n";
std::vector<std::string> splitParts(Input in, std::size_t maxParts);

/// A scratch folder for this process (under $TMPDIR), emptied by clear() and removed at exit.
class Scratch {
  public:
    static Scratch& get();
    /// Removes every file written so far.
    void clear();
    /// Writes `bytes` to `name` in the folder; returns its path.
    std::filesystem::path write(const std::string& name, std::string_view bytes);
    std::filesystem::path path(const std::string& name) const { return dir_ / name; }
    const std::filesystem::path& dir() const { return dir_; }
    ~Scratch();

  private:
    Scratch();
    std::filesystem::path dir_;
};

/// Empties the scratch folder and writes `bytes` to `name` in it: the input as one file.
inline std::filesystem::path freshFile(const std::string& name, std::string_view bytes) {
    Scratch::get().clear();
    return Scratch::get().write(name, bytes);
}

/// Checks an error message: non-empty, one line, no control characters, valid UTF-8.
void checkMessage(const std::string& message);

/// Runs `read` with stderr (fd 2) captured; a UdvrError must carry a well-formed message
/// (checkMessage) and nothing may have been written to stderr before it (the CLI's error is
/// one line; notes are printed only after a read succeeded); any other exception is a finding.
/// Returns true when `read` returned normally.
bool expectCleanResult(const std::function<void()>& read);

/// A value read from the front of the input (little-endian), or 0 past its end; advances `in`.
template <class T>
T take(Input& in) {
    T v{};
    std::uint8_t b[sizeof(T)] = {};
    const std::size_t n = in.size() < sizeof(T) ? in.size() : sizeof(T);
    for (std::size_t i = 0; i < n; ++i) b[i] = in[i];
    in = in.subspan(n);
    __builtin_memcpy(&v, b, sizeof(T));
    return v;
}

}  // namespace udvr::fuzz

#ifdef UDVR_FUZZ_LIBFUZZER
#define UDVR_FUZZ_TARGET(name)                                                          \
    static void udvrFuzzTarget_##name(::udvr::fuzz::Input input);                       \
    extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) { \
        udvrFuzzTarget_##name(::udvr::fuzz::Input(data, size));                         \
        return 0;                                                                       \
    }                                                                                   \
    static void udvrFuzzTarget_##name(::udvr::fuzz::Input input)
#else
#define UDVR_FUZZ_TARGET(name)                                       \
    static void udvrFuzzTarget_##name(::udvr::fuzz::Input input);    \
    [[maybe_unused]] static const bool udvrFuzzRegistered_##name =   \
        ::udvr::fuzz::registerTarget(#name, &udvrFuzzTarget_##name); \
    static void udvrFuzzTarget_##name(::udvr::fuzz::Input input)
#endif
