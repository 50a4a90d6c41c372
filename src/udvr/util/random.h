#pragma once
// Counter-based random numbers: the value for (seed, stream, index) does not depend on the order
// or thread in which it is drawn, so parallel loops stay reproducible for any thread count.
#include <cmath>
#include <cstdint>

#include "udvr/util/check.h"

namespace udvr {

/// SplitMix64 finaliser (Steele et al. 2014): a bijective 64-bit mix.
UDVR_CPU_GPU inline std::uint64_t mix64(std::uint64_t z) {
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

/// A small stream generator seeded from (seed, stream, index).
class CounterRng {
  public:
    UDVR_CPU_GPU CounterRng(std::uint64_t seed, std::uint64_t stream, std::uint64_t index)
        : state_(mix64(mix64(mix64(seed) ^ stream) ^ index)) {}
    /// Next 64 random bits.
    UDVR_CPU_GPU std::uint64_t nextBits() { return mix64(state_++); }
    /// Uniform in [0, 1) with 53 random bits.
    UDVR_CPU_GPU double uniform() { return static_cast<double>(nextBits() >> 11) * 0x1.0p-53; }
    /// Uniform in (0, 1): never 0, safe for log().
    UDVR_CPU_GPU double uniformOpen() {
        return (static_cast<double>(nextBits() >> 11) + 0.5) * 0x1.0p-53;
    }
    /// Standard normal (Box–Muller; one of the pair is discarded for statelessness).
    UDVR_CPU_GPU double normal() {
        const double u1 = uniformOpen(), u2 = uniform();
        return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
    }

  private:
    std::uint64_t state_;
};

}  // namespace udvr
