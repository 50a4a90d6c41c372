#include "udvr/util/memory.h"

#include <gtest/gtest.h>

#include "udvr/util/check.h"

namespace udvr {

TEST(Memory, ParsesSizesWithBinarySuffixes) {
    EXPECT_EQ(parseByteSize("123456", "--memory-limit"), 123456u);
    EXPECT_EQ(parseByteSize("512M", "--memory-limit"), 512u << 20);
    EXPECT_EQ(parseByteSize("4g", "--memory-limit"), std::size_t{4} << 30);
    EXPECT_EQ(parseByteSize("1.5GiB", "--memory-limit"), std::size_t{3} << 29);
    EXPECT_EQ(parseByteSize("2KB", "--memory-limit"), 2048u);
    EXPECT_EQ(parseByteSize("1T", "--memory-limit"), std::size_t{1} << 40);
    EXPECT_EQ(parseByteSize("100B", "--memory-limit"), 100u);
}

TEST(Memory, BadSizesAreOneLineErrors) {
    for (const char* bad : {"", "abc", "0", "-5", "4X", "G", "1.5.2G", "4GG", "0.1", "1e9"}) {
        try {
            parseByteSize(bad, "--memory-limit");
            ADD_FAILURE() << "accepted '" << bad << "'";
        } catch (const UdvrError& e) {
            const std::string what = e.what();
            EXPECT_NE(what.find("--memory-limit"), std::string::npos) << what;
            EXPECT_EQ(what.find('\n'), std::string::npos) << what;
        }
    }
}

TEST(Memory, SizesReadAsText) {
    EXPECT_EQ(byteSizeText(100), "100 B");
    EXPECT_EQ(byteSizeText(1536), "1.50 KiB");
    EXPECT_EQ(byteSizeText(std::size_t{20} << 30), "20.0 GiB");
    EXPECT_EQ(byteSizeText(std::size_t{512} << 20), "512 MiB");
}

TEST(Memory, HeadroomAndResidentSizeAreKnownOnLinux) {
    const MemoryHeadroom h = memoryHeadroom();
    EXPECT_GT(h.bytes, 0u);
    EXPECT_FALSE(h.source.empty());
    EXPECT_GT(residentBytes(), 0u);
}

}  // namespace udvr
