#pragma once
// What this build was compiled for: the CPU target chosen in CMake (UDVR_ARCH, passed as
// UDVR_ARCH_NAME) and the vector register whose width in floats is the ray loop's batch, read
// from the compiler's predefined macros. `udvr --version` and Python's `udvr.__build__` print it.
#include <string_view>

#ifndef UDVR_ARCH_NAME
#define UDVR_ARCH_NAME "unknown"  // compiled outside CMake
#endif
#ifndef UDVR_VERSION
#define UDVR_VERSION "0.1.0"
#endif

// The instruction set of the ray loop's batches: one vector register of floats (util/lanes.h
// picks the batch width from the same macros). AVX-512F implies FMA.
#if defined(__AVX512F__)
#define UDVR_BUILD_ISA "AVX-512"
#define UDVR_BUILD_REGISTER_BITS 512
#define UDVR_BUILD_LANES "16 floats (512 bits)"
#elif defined(__AVX2__) && defined(__FMA__)
#define UDVR_BUILD_ISA "AVX2+FMA"
#define UDVR_BUILD_REGISTER_BITS 256
#define UDVR_BUILD_LANES "8 floats (256 bits)"
#elif defined(__AVX2__)
#define UDVR_BUILD_ISA "AVX2"
#define UDVR_BUILD_REGISTER_BITS 256
#define UDVR_BUILD_LANES "8 floats (256 bits)"
#elif defined(__AVX__)  // float arithmetic on 256 bits, integer lanes split in two halves
#define UDVR_BUILD_ISA "AVX"
#define UDVR_BUILD_REGISTER_BITS 256
#define UDVR_BUILD_LANES "8 floats (256 bits)"
#elif defined(__SSE2__)  // the x86-64 baseline
#define UDVR_BUILD_ISA "SSE2"
#define UDVR_BUILD_REGISTER_BITS 128
#define UDVR_BUILD_LANES "4 floats (128 bits)"
#elif defined(__ARM_NEON)  // the armv8-a baseline
#define UDVR_BUILD_ISA "NEON"
#define UDVR_BUILD_REGISTER_BITS 128
#define UDVR_BUILD_LANES "4 floats (128 bits)"
#else  // GCC splits the vectors into scalar operations
#define UDVR_BUILD_ISA "scalar"
#define UDVR_BUILD_REGISTER_BITS 0
#define UDVR_BUILD_LANES "4 floats (scalar operations)"
#endif

namespace udvr::build {

/// The release, as `udvr --version` and Python's `udvr.__version__` print it ("0.1.0").
inline constexpr std::string_view kVersion = UDVR_VERSION;

/// The CMake CPU target: "native", "x86-64-v4", "x86-64-v3" or "generic".
inline constexpr std::string_view kArchName = UDVR_ARCH_NAME;

/// The vector instruction set in use: "AVX-512", "AVX2+FMA", "AVX2", "AVX", "SSE2", "NEON" or
/// "scalar".
inline constexpr std::string_view kIsa = UDVR_BUILD_ISA;

/// Floats per batch of the ray loop: one register (lanes::kWidth).
inline constexpr int kBatchLanes =
    UDVR_BUILD_REGISTER_BITS >= 128 ? UDVR_BUILD_REGISTER_BITS / 32 : 4;

/// Width of one vector register in bits (0: no vector registers).
inline constexpr int kRegisterBits = UDVR_BUILD_REGISTER_BITS;

/// Vector registers per batch (0: no vector registers).
inline constexpr int kRegistersPerBatch = kRegisterBits == 0 ? 0 : 1;

/// e.g. "target native: AVX-512, batches of 16 floats (512 bits)".
constexpr std::string_view buildDescription() {
    return "target " UDVR_ARCH_NAME ": " UDVR_BUILD_ISA ", batches of " UDVR_BUILD_LANES;
}

/// e.g. "udvr 0.1.0 (target native: AVX-512, batches of 16 floats (512 bits))".
constexpr std::string_view versionLine() {
    return "udvr " UDVR_VERSION " (target " UDVR_ARCH_NAME ": " UDVR_BUILD_ISA
           ", batches of " UDVR_BUILD_LANES ")";
}

}  // namespace udvr::build
