#include "udvr/io/npy.h"

#include <gtest/gtest.h>

#include <string>

#include "udvr/io/io_test_util.h"

namespace udvr {
namespace {

using testing::expectUdvrError;

// A .npy header written by hand: magic, version, little-endian length, dict (unpadded).
std::string header(const std::string& dict, int major = 1) {
    std::string out("\x93NUMPY", 6);
    out.push_back(static_cast<char>(major));
    out.push_back('\0');
    const std::size_t n = dict.size();
    for (int b = 0; b < (major == 1 ? 2 : 4); ++b)
        out.push_back(static_cast<char>((n >> (8 * b)) & 0xFF));
    return out + dict;
}

TEST(Tf2NpyHeader, ParsesWhatNumPyWrites) {
    const std::string dict = "{'descr': '<f4', 'fortran_order': False, 'shape': (3, 5, 4), }";
    const NpyHeader h = parseNpyHeader(header(dict + std::string(20, ' ') + "\n"), "a.npy");
    EXPECT_EQ(h.majorVersion, 1);
    EXPECT_EQ(h.descr, "<f4");
    EXPECT_FALSE(h.fortranOrder);
    EXPECT_EQ(h.shape, (std::vector<long long>{3, 5, 4}));
    EXPECT_EQ(h.dataOffset, 10 + dict.size() + 21);
    EXPECT_EQ(h.elementCount(), 60u);
}

TEST(Tf2NpyHeader, ToleratesSpellingsOfTheLiteral) {
    // Double quotes, other key order, no spaces, no trailing comma, version 2 and 3 lengths.
    const NpyHeader a = parseNpyHeader(
        header("{\"shape\":(7,),\"fortran_order\":True,\"descr\":\"|u1\"}", 2), "b.npy");
    EXPECT_EQ(a.majorVersion, 2);
    EXPECT_EQ(a.shape, (std::vector<long long>{7}));
    EXPECT_TRUE(a.fortranOrder);
    EXPECT_EQ(a.descr, "|u1");
    const std::string scalar = "{'descr': '<f8', 'fortran_order': False, 'shape': (), }\n";
    const NpyHeader b = parseNpyHeader(header(scalar, 3), "c.npy");
    EXPECT_TRUE(b.shape.empty());
    EXPECT_EQ(b.elementCount(), 1u);
    EXPECT_EQ(b.dataOffset, 12 + scalar.size());
    // Python 2 longs.
    const NpyHeader c = parseNpyHeader(
        header("{'descr': '<f4', 'fortran_order': False, 'shape': (2L, 3L), }"), "d.npy");
    EXPECT_EQ(c.shape, (std::vector<long long>{2, 3}));
}

TEST(Tf2NpyHeader, WriterPadsTo64AndParsesBack) {
    for (const auto& shape : {std::vector<long long>{256, 256, 4}, std::vector<long long>{9},
                              std::vector<long long>{}}) {
        const std::string bytes = npyHeaderBytes("<f4", shape);
        EXPECT_EQ(bytes.size() % 64, 0u);
        EXPECT_EQ(bytes.back(), '\n');
        const NpyHeader h = parseNpyHeader(bytes, "w.npy");
        EXPECT_EQ(h.shape, shape);
        EXPECT_EQ(h.descr, "<f4");
        EXPECT_EQ(h.dataOffset, bytes.size());
    }
}

TEST(Tf2NpyHeader, BadHeadersGiveOneLineErrors) {
    const std::string ok = "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 2, 4), }";
    expectUdvrError([] { parseNpyHeader("PK\x03\x04 not numpy", "x.npy"); },
                    {"x.npy", "bad magic"});
    expectUdvrError([] { parseNpyHeader(std::string("\x93NUMPY\x01", 7), "x.npy"); },
                    {"x.npy", "truncated"});
    expectUdvrError([&] { parseNpyHeader(header(ok, 4), "x.npy"); }, {"x.npy", "version 4"});
    expectUdvrError([&] { parseNpyHeader(header(ok).substr(0, 30), "x.npy"); },
                    {"x.npy", "truncated NPY header"});
    expectUdvrError(
        [] { parseNpyHeader(header("{'descr': '<f4', 'shape': (2, 2, 4), }"), "x.npy"); },
        {"x.npy", "'fortran_order'"});
    expectUdvrError(
        [] {
            parseNpyHeader(header("{'descr': '<f4', 'fortran_order': 0, 'shape': (2,), }"),
                           "x.npy");
        },
        {"x.npy", "True or False"});
    expectUdvrError(
        [] {
            parseNpyHeader(header("{'descr': '<f4', 'fortran_order': False, 'shape': (2, -1), }"),
                           "x.npy");
        },
        {"x.npy", "non-negative"});
    expectUdvrError(
        [] {
            parseNpyHeader(
                header("{'descr': [('a', '<f4')], 'fortran_order': False, 'shape': (2,), }"),
                "x.npy");
        },
        {"x.npy", "structured"});
    expectUdvrError(
        [] {
            parseNpyHeader(header("{'descr': '<f4', 'fortran_order': False, 'shape': (2, 2"),
                           "x.npy");
        },
        {"x.npy", "malformed NPY header"});
    expectUdvrError(
        [] {
            parseNpyHeader(header("{'descr': '<f4' 'fortran_order': False, 'shape': (2,)}"),
                           "x.npy");
        },
        {"x.npy", "expected ',' or '}'"});
    expectUdvrError(
        [] {
            parseNpyHeader(header("{'descr': '<f4', 'fortran_order': Maybe, 'shape': (2,)}"),
                           "x.npy");
        },
        {"x.npy", "unexpected 'M'"});
}

}  // namespace
}  // namespace udvr
