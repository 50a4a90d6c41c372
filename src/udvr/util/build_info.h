#pragma once
// What this build was compiled for: the CPU target chosen in CMake (UDVR_ARCH, passed as
// UDVR_ARCH_NAME) and the vector registers that the ray loop's 16-float batches map onto, read
// from the compiler's predefined macros. `udvr --version` and Python's `udvr.__build__` print it.
#include <string_view>

#ifndef UDVR_ARCH_NAME
#define UDVR_ARCH_NAME "unknown"  // compiled outside CMake
#endif
#ifndef UDVR_VERSION
#define UDVR_VERSION "0.1.0"
#endif

// The instruction set whose registers GCC uses for a 64-byte float vector, and how many of them
// one 16-float batch takes. AVX-512F implies FMA; AVX2 without FMA only on odd -march choices.
#if defined(__AVX512F__)
#define UDVR_BUILD_ISA "AVX-512"
#define UDVR_BUILD_REGISTER_BITS 512
#define UDVR_BUILD_REGISTERS "1 register of 512 bits"
#elif defined(__AVX2__) && defined(__FMA__)
#define UDVR_BUILD_ISA "AVX2+FMA"
#define UDVR_BUILD_REGISTER_BITS 256
#define UDVR_BUILD_REGISTERS "2 registers of 256 bits"
#elif defined(__AVX2__)
#define UDVR_BUILD_ISA "AVX2"
#define UDVR_BUILD_REGISTER_BITS 256
#define UDVR_BUILD_REGISTERS "2 registers of 256 bits"
#elif defined(__AVX__)  // float arithmetic on 256 bits, integer lanes split in two halves
#define UDVR_BUILD_ISA "AVX"
#define UDVR_BUILD_REGISTER_BITS 256
#define UDVR_BUILD_REGISTERS "2 registers of 256 bits"
#elif defined(__SSE2__)  // the x86-64 baseline
#define UDVR_BUILD_ISA "SSE2"
#define UDVR_BUILD_REGISTER_BITS 128
#define UDVR_BUILD_REGISTERS "4 registers of 128 bits"
#elif defined(__ARM_NEON)  // the armv8-a baseline
#define UDVR_BUILD_ISA "NEON"
#define UDVR_BUILD_REGISTER_BITS 128
#define UDVR_BUILD_REGISTERS "4 registers of 128 bits"
#else  // GCC splits the vectors into scalar operations
#define UDVR_BUILD_ISA "scalar"
#define UDVR_BUILD_REGISTER_BITS 0
#define UDVR_BUILD_REGISTERS "scalar operations"
#endif

namespace udvr::build {

/// The CMake CPU target: "native", "x86-64-v4", "x86-64-v3" or "generic".
inline constexpr std::string_view kArchName = UDVR_ARCH_NAME;

/// The vector instruction set in use: "AVX-512", "AVX2+FMA", "AVX2", "AVX", "SSE2", "NEON" or
/// "scalar".
inline constexpr std::string_view kIsa = UDVR_BUILD_ISA;

/// Floats per batch of the ray loop, on every target.
inline constexpr int kBatchLanes = 16;

/// Width of one vector register in bits (0: no vector registers).
inline constexpr int kRegisterBits = UDVR_BUILD_REGISTER_BITS;

/// Vector registers per 16-float batch (0: no vector registers).
inline constexpr int kRegistersPerBatch = kRegisterBits == 0 ? 0 : kBatchLanes * 32 / kRegisterBits;

/// e.g. "target native: AVX-512, 16-float lanes in 1 register of 512 bits".
constexpr std::string_view buildDescription() {
    return "target " UDVR_ARCH_NAME ": " UDVR_BUILD_ISA ", 16-float lanes in " UDVR_BUILD_REGISTERS;
}

/// e.g. "udvr 0.1.0 (target native: AVX-512, 16-float lanes in 1 register of 512 bits)".
constexpr std::string_view versionLine() {
    return "udvr " UDVR_VERSION " (target " UDVR_ARCH_NAME ": " UDVR_BUILD_ISA
           ", 16-float lanes in " UDVR_BUILD_REGISTERS ")";
}

}  // namespace udvr::build
