#include "udvr/util/build_info.h"

#include <gtest/gtest.h>

#include <string>
#include <string_view>

#include "udvr/util/lanes.h"

namespace udvr::build {
namespace {

bool contains(std::string_view s, std::string_view part) {
    return s.find(part) != std::string_view::npos;
}

#if defined(__AVX512F__)
constexpr bool kAvx512 = true;
#else
constexpr bool kAvx512 = false;
#endif
#if defined(__AVX2__)
constexpr bool kAvx2 = true;
#else
constexpr bool kAvx2 = false;
#endif
#if defined(__FMA__)
constexpr bool kFma = true;
#else
constexpr bool kFma = false;
#endif
#if defined(__SSE2__)
constexpr bool kSse2 = true;
#else
constexpr bool kSse2 = false;
#endif
#if defined(__ARM_NEON)
constexpr bool kNeon = true;
#else
constexpr bool kNeon = false;
#endif

TEST(BuildInfo, NamesTheCMakeTarget) {
    const std::string_view arch = UDVR_ARCH_NAME;
    EXPECT_TRUE(arch == "native" || arch == "x86-64-v4" || arch == "x86-64-v3" || arch == "generic")
        << arch;
    EXPECT_EQ(kArchName, arch);
    EXPECT_TRUE(buildDescription().starts_with("target " + std::string(arch) + ": "))
        << buildDescription();
}

TEST(BuildInfo, IsaMatchesThePredefinedMacros) {
    const std::string_view d = buildDescription();
    EXPECT_EQ(contains(d, "AVX-512"), kAvx512) << d;
    EXPECT_EQ(contains(d, "AVX2"), kAvx2 && !kAvx512) << d;
    EXPECT_EQ(contains(d, "AVX2+FMA"), kAvx2 && kFma && !kAvx512) << d;
    EXPECT_EQ(contains(d, "SSE2"), kSse2 && !kAvx2 && !kAvx512 && kIsa != "AVX") << d;
    EXPECT_EQ(contains(d, "NEON"), kNeon && !kSse2) << d;
    EXPECT_TRUE(contains(d, std::string(kIsa) + ", ")) << d;
}

TEST(BuildInfo, TheCMakeTargetImpliesTheIsa) {
    // x86-64-v4 includes AVX-512F, x86-64-v3 AVX2 and FMA but not AVX-512; generic on x86-64 is
    // SSE2 only (arm64: NEON).
    const std::string_view arch = kArchName;
    if (arch == "x86-64-v4") {
        EXPECT_EQ(kIsa, "AVX-512");
    } else if (arch == "x86-64-v3") {
        EXPECT_EQ(kIsa, "AVX2+FMA");
    } else if (arch == "generic") {
        EXPECT_TRUE(kIsa == "SSE2" || kIsa == "NEON" || kIsa == "scalar") << kIsa;
    }
}

TEST(BuildInfo, OneRegisterHoldsOneBatch) {
    EXPECT_EQ(kBatchLanes, lanes::kWidth);  // the width the ray loop really uses
    const std::string_view d = buildDescription();
    const std::string lanesText = "batches of " + std::to_string(kBatchLanes) + " floats (";
    EXPECT_TRUE(contains(d, lanesText)) << d;
    if (kIsa == "scalar") {
        EXPECT_EQ(kRegisterBits, 0);
        return;
    }
    EXPECT_EQ(kRegistersPerBatch, 1);
    EXPECT_EQ(kRegisterBits, kBatchLanes * 32);
    EXPECT_TRUE(d.ends_with(std::to_string(kRegisterBits) + " bits)")) << d;
    if (kAvx512) {
        EXPECT_EQ(kRegisterBits, 512);
    } else if (kAvx2) {
        EXPECT_EQ(kRegisterBits, 256);
    } else if (kIsa == "SSE2" || kIsa == "NEON") {
        EXPECT_EQ(kRegisterBits, 128);
    }
}

TEST(BuildInfo, VersionLineWrapsTheDescription) {
    const std::string expected = "udvr " UDVR_VERSION " (" + std::string(buildDescription()) + ")";
    EXPECT_EQ(versionLine(), expected);
    static_assert(versionLine().starts_with("udvr "));
}

}  // namespace
}  // namespace udvr::build
