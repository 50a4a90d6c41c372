// UdvrError messages: one printable line of valid UTF-8, whatever bytes they quote.
#include "udvr/util/check.h"

#include <gtest/gtest.h>

namespace udvr {
namespace {

TEST(Check, PrintableLineEscapesControlsAndMalformedUtf8) {
    using detail::printableLine;
    EXPECT_EQ(printableLine("plain text: 1.5 (x)"), "plain text: 1.5 (x)");
    EXPECT_EQ(printableLine("caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80"),
              "caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80");  // é € 😀 stay
    EXPECT_EQ(printableLine("a\nb\tc\r\x7f"), "a\\x0ab\\x09c\\x0d\\x7f");
    EXPECT_EQ(printableLine(std::string("nul\0end", 7)), "nul\\x00end");
    EXPECT_EQ(printableLine("\xff\xfe"), "\\xff\\xfe");
    EXPECT_EQ(printableLine("\xc0\xaf"), "\\xc0\\xaf");                    // overlong '/'
    EXPECT_EQ(printableLine("\xe0\x80\xaf"), "\\xe0\\x80\\xaf");           // overlong
    EXPECT_EQ(printableLine("\xed\xa0\x80"), "\\xed\\xa0\\x80");           // a surrogate
    EXPECT_EQ(printableLine("\xf4\x90\x80\x80"), "\\xf4\\x90\\x80\\x80");  // above U+10FFFF
    EXPECT_EQ(printableLine("\xc2\x85"), "\\xc2\\x85");                    // C1 control (NEL)
    EXPECT_EQ(printableLine("cut \xe2\x82"), "cut \\xe2\\x82");
}

TEST(Check, UdvrErrorMessagesArePrintable) {
    const UdvrError e("f.nrrd: unknown field 'a\nb\xff'");
    EXPECT_STREQ(e.what(), "f.nrrd: unknown field 'a\\x0ab\\xff'");
    try {
        UDVR_FAIL("line 1\nline 2");
    } catch (const UdvrError& err) {
        EXPECT_STREQ(err.what(), "line 1\\x0aline 2");
    }
}

}  // namespace
}  // namespace udvr
