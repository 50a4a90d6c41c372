#pragma once
// Checks and user-facing errors.
//  - UdvrError: a user error (bad input, bad flag). The CLI prints what() on one line, exits 2.
//  - FileError: a UdvrError about a file that cannot be found, opened, read or written (not about
//    its contents); Python raises OSError for it, ValueError for other UdvrErrors.
//  - UDVR_CHECK: an always-on invariant; throws InternalError with file:line.
//  - UDVR_DCHECK: same, debug builds only.
#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>

namespace udvr {

namespace detail {
/// `text` as one printable line of valid UTF-8: control characters (C0, DEL, C1) and bytes
/// that are not well-formed UTF-8 become \xNN. Error messages quote file contents (a NRRD line,
/// a VTK attribute, a NetCDF name); the CLI prints them on one line of a UTF-8 terminal.
inline std::string printableLine(std::string_view text) {
    static constexpr char kHex[] = "0123456789abcdef";
    std::string out;
    out.reserve(text.size());
    const auto escape = [&](unsigned char c) {
        out += "\\x";
        out += kHex[c >> 4];
        out += kHex[c & 15];
    };
    for (std::size_t i = 0; i < text.size();) {
        const auto c = static_cast<unsigned char>(text[i]);
        if (c < 0x80) {
            if (c < 0x20 || c == 0x7F)
                escape(c);
            else
                out += static_cast<char>(c);
            ++i;
            continue;
        }
        // A well-formed sequence (RFC 3629: no overlongs, no surrogates, at most U+10FFFF) that
        // is not a C1 control character is copied; anything else is escaped byte by byte.
        const std::size_t len = c >= 0xC2 && c <= 0xDF   ? 2
                                : c >= 0xE0 && c <= 0xEF ? 3
                                : c >= 0xF0 && c <= 0xF4 ? 4
                                                         : 0;
        std::uint32_t cp = c & (len == 2 ? 0x1F : len == 3 ? 0x0F : 0x07);
        bool ok = len > 0 && i + len <= text.size();
        for (std::size_t k = 1; ok && k < len; ++k) {
            const auto cc = static_cast<unsigned char>(text[i + k]);
            ok = (cc & 0xC0) == 0x80;
            cp = (cp << 6) | (cc & 0x3F);
        }
        ok = ok && !(len == 3 && cp < 0x800) && !(len == 4 && (cp < 0x10000 || cp > 0x10FFFF)) &&
             !(cp >= 0xD800 && cp <= 0xDFFF) && !(cp >= 0x80 && cp <= 0x9F);
        if (ok) {
            out.append(text.substr(i, len));
            i += len;
        } else {
            escape(c);
            ++i;
        }
    }
    return out;
}
}  // namespace detail

/// A user error: the message says what was wrong and what was expected. One line, printable
/// (detail::printableLine escapes control characters and malformed UTF-8).
class UdvrError : public std::runtime_error {
  public:
    explicit UdvrError(const std::string& message)
        : std::runtime_error(detail::printableLine(message)) {}
};

/// A user error about a path: missing, not a regular file, cannot be opened, read or written.
class FileError : public UdvrError {
  public:
    using UdvrError::UdvrError;
};

/// A violated invariant (a bug, not bad input).
class InternalError : public std::logic_error {
  public:
    explicit InternalError(const std::string& message) : std::logic_error(message) {}
};

namespace detail {
[[noreturn]] inline void checkFailed(const char* expr, const char* file, int line,
                                     const std::string& message) {
    std::ostringstream os;
    os << "internal check failed: " << expr << " at " << file << ":" << line;
    if (!message.empty()) os << " (" << message << ")";
    throw InternalError(os.str());
}
}  // namespace detail

}  // namespace udvr

#define UDVR_CHECK(cond)                                                         \
    do {                                                                         \
        if (!(cond)) ::udvr::detail::checkFailed(#cond, __FILE__, __LINE__, ""); \
    } while (0)
#define UDVR_CHECK_MSG(cond, msg)                                                   \
    do {                                                                            \
        if (!(cond)) ::udvr::detail::checkFailed(#cond, __FILE__, __LINE__, (msg)); \
    } while (0)
#ifndef NDEBUG
#define UDVR_DCHECK(cond) UDVR_CHECK(cond)
#else
#define UDVR_DCHECK(cond) \
    do {                  \
    } while (0)
#endif

/// Throw an exception of type `type` (constructed from a string) built with stream syntax.
#define UDVR_THROW(type, stream_expr)     \
    do {                                  \
        std::ostringstream udvr_fail_os_; \
        udvr_fail_os_ << stream_expr;     \
        throw type(udvr_fail_os_.str());  \
    } while (0)

/// Throw a UdvrError built with stream syntax: UDVR_FAIL("dims " << n << " do not match").
#define UDVR_FAIL(stream_expr) UDVR_THROW(::udvr::UdvrError, stream_expr)

/// Throw a FileError built with stream syntax (as UDVR_FAIL).
#define UDVR_FILE_FAIL(stream_expr) UDVR_THROW(::udvr::FileError, stream_expr)

#ifdef __CUDACC__
#define UDVR_CPU_GPU __host__ __device__
#else
#define UDVR_CPU_GPU
#endif
/// For the small bodies of the per-sample kernels: inlined into the ray loop even where GCC's
/// heuristics would call them (a call passes 16-lane vectors through memory).
#define UDVR_INLINE inline __attribute__((always_inline))
/// The same for a lambda, after its parameter list: `[&](int j) UDVR_INLINE_LAMBDA { … }` (the
/// ray step's flatten does not reach through every lambda a distribution is handed to).
#define UDVR_INLINE_LAMBDA __attribute__((always_inline))
/// For the ray loop's step: everything it calls is inlined into it (GCC's inliner otherwise stops
/// at its growth limits and passes the batch's vectors through memory: +30 % on quantile-range).
#define UDVR_FLATTEN __attribute__((flatten))
/// For cold paths inside flattened code (the double fallback of a few lanes).
#define UDVR_NOINLINE __attribute__((noinline))
