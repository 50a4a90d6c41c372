// Raw and NRRD readers: round trips on files written here, and every bad-input case.
#include "udvr/io/field_io.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "udvr/io/io_test_util.h"

namespace udvr {
namespace {

using testing::bytesOf;
using testing::expectUdvrError;
using testing::TempDir;
using testing::writeBytes;

/// 4×3×2 values with v(i,j,k) = i + 10j + 100k.
template <class T>
std::vector<T> ramp() {
    std::vector<T> v;
    for (int k = 0; k < 2; ++k)
        for (int j = 0; j < 3; ++j)
            for (int i = 0; i < 4; ++i) v.push_back(static_cast<T>(i + 10 * j + 100 * k));
    return v;
}

void expectRamp(const ScalarField& f) {
    ASSERT_EQ(f.grid.dims, (std::array<int, 3>{4, 3, 2}));
    ASSERT_EQ(f.values.size(), 24u);
    EXPECT_EQ(f.values[f.grid.index(3, 2, 1)], 123.f);
    EXPECT_EQ(f.values[f.grid.index(1, 0, 1)], 101.f);
}

std::string gzip(const std::string& data) {
    z_stream zs{};
    EXPECT_EQ(deflateInit2(&zs, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY), Z_OK);
    std::string out(deflateBound(&zs, static_cast<uLong>(data.size())) + 32, '\0');
    zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
    zs.avail_in = static_cast<uInt>(data.size());
    zs.next_out = reinterpret_cast<Bytef*>(out.data());
    zs.avail_out = static_cast<uInt>(out.size());
    EXPECT_EQ(deflate(&zs, Z_FINISH), Z_STREAM_END);
    out.resize(zs.total_out);
    deflateEnd(&zs);
    return out;
}

std::string header(const std::string& type, const std::string& extra) {
    return "NRRD0004\n# written by the udvr io test\ntype: " + type +
           "\ndimension: 3\nsizes: 4 3 2\n" + extra;
}

TEST(IoRaw, ReadsEveryTypeAndByteOrder) {
    TempDir dir;
    RawLayout layout;
    layout.dims = {4, 3, 2};
    layout.spacing = {0.5, 2.0, 3.0};
    layout.origin = {1.0, -2.0, 0.0};
    FieldReadOptions o;
    auto check = [&](const std::string& type, const std::string& bytes) {
        writeBytes(dir / "f.raw", bytes);
        o.raw = layout;
        o.raw.type = type;
        ScalarField f = readField(dir / "f.raw", o);
        SCOPED_TRACE(type);
        expectRamp(f);
        EXPECT_EQ(f.valueType, type);
        EXPECT_EQ(f.valueStep, type.rfind("float", 0) == 0 ? 0.0 : 1.0);
        EXPECT_EQ(f.grid.spacing, layout.spacing);
        EXPECT_EQ(f.grid.origin, layout.origin);
    };
    check("uint8", bytesOf(ramp<std::uint8_t>()));
    check("int8", bytesOf(ramp<std::int8_t>()));  // 123 still fits
    check("uint16", bytesOf(ramp<std::uint16_t>()));
    check("int16", bytesOf(ramp<std::int16_t>()));
    check("uint32", bytesOf(ramp<std::uint32_t>()));
    check("int32", bytesOf(ramp<std::int32_t>()));
    check("float32", bytesOf(ramp<float>()));
    check("float64", bytesOf(ramp<double>()));
    // Big endian: swap each uint16 by hand.
    std::string big = bytesOf(ramp<std::uint16_t>());
    for (std::size_t i = 0; i < big.size(); i += 2) std::swap(big[i], big[i + 1]);
    layout.bigEndian = true;
    check("uint16", big);
}

TEST(IoRaw, RejectsBadInput) {
    TempDir dir;
    FieldReadOptions o;
    o.raw.dims = {4, 3, 2};
    o.raw.type = "float32";
    writeBytes(dir / "short.raw", bytesOf(ramp<float>()).substr(0, 90));
    expectUdvrError([&] { readField(dir / "short.raw", o); },
                    {"short.raw", "truncated", "expected 96 bytes", "found 90"});
    writeBytes(dir / "long.raw", bytesOf(ramp<float>()) + "xxxx");
    expectUdvrError([&] { readField(dir / "long.raw", o); }, {"long.raw", "dims", "100"});
    // A size that fits another layout names it: another type, or cubic dims.
    writeBytes(dir / "u8.raw", std::string(24, '\1'));
    expectUdvrError([&] { readField(dir / "u8.raw", o); },
                    {"u8.raw", "size 24 bytes", "4x3x2 float32 (96 bytes)", "fits uint8 4x3x2",
                     "--type uint8"});
    writeBytes(dir / "cube.raw", std::string(4 * 27, '\0'));
    expectUdvrError([&] { readField(dir / "cube.raw", o); },
                    {"cube.raw", "fits float32 3x3x3", "--dims 3"});
    writeBytes(dir / "cube8.raw", std::string(125, '\1'));
    expectUdvrError([&] { readField(dir / "cube8.raw", o); },
                    {"cube8.raw", "fits uint8 5x5x5", "--dims 5 --type uint8"});
    expectUdvrError([&] { readField(dir / "missing.raw", o); }, {"missing.raw", "no such file"});
    o.raw.type = "complex64";
    expectUdvrError([&] { readField(dir / "long.raw", o); }, {"unsupported raw type 'complex64'"});
    FieldReadOptions noLayout;
    expectUdvrError([&] { readField(dir / "long.raw", noLayout); }, {"long.raw", "dims"});
    std::vector<float> nan = ramp<float>();
    nan[nan.size() - 1] = std::numeric_limits<float>::quiet_NaN();
    nan[5] = std::numeric_limits<float>::infinity();
    writeBytes(dir / "nan.raw", bytesOf(nan));
    o.raw.type = "float32";
    expectUdvrError([&] { readField(dir / "nan.raw", o); },
                    {"nan.raw", "1 NaN and 1 Inf", "(1,1,0)"});
}

TEST(IoNrrd, DetachedRawWithGeometry) {
    TempDir dir;
    writeBytes(dir / "f.raw", bytesOf(ramp<std::int16_t>()));
    writeBytes(dir / "f.nhdr", header("short",
                                      "endian: little\nencoding: raw\n"
                                      "space: right-anterior-superior\n"
                                      "space directions: (0.5,0,0) (0,2,0) (0,0,3)\n"
                                      "space origin: (1,-2,0.25)\n"
                                      "kinds: domain domain domain\n"
                                      "key:=value\n"
                                      "data file: f.raw\n"));
    ScalarField f = readField(dir / "f.nhdr");
    expectRamp(f);
    EXPECT_EQ(f.valueType, "int16");  // any spelling of the type, by its canonical name
    EXPECT_EQ(f.valueStep, 1.0);
    EXPECT_EQ(f.grid.spacing, (std::array<double, 3>{0.5, 2.0, 3.0}));
    EXPECT_EQ(f.grid.origin, (std::array<double, 3>{1.0, -2.0, 0.25}));
}

TEST(IoNrrd, AttachedGzipBigEndianDouble) {
    TempDir dir;
    std::string data = bytesOf(ramp<double>());
    for (std::size_t i = 0; i < data.size(); i += 8) std::reverse(&data[i], &data[i] + 8);
    writeBytes(dir / "f.nrrd", header("double",
                                      "spacings: 1.5 1 2\nendian: big\n"
                                      "encoding: gzip\n\n") +
                                   gzip(data));
    ScalarField f = readField(dir / "f.nrrd");
    expectRamp(f);
    EXPECT_EQ(f.valueType, "float64");
    EXPECT_EQ(f.valueStep, 0.0);
    EXPECT_EQ(f.grid.spacing, (std::array<double, 3>{1.5, 1.0, 2.0}));
    EXPECT_EQ(f.grid.origin, (std::array<double, 3>{0.0, 0.0, 0.0}));
}

TEST(IoNrrd, DetachedGzipAndAsciiAndAllTypes) {
    TempDir dir;
    writeBytes(dir / "g.raw.gz", gzip(bytesOf(ramp<std::uint32_t>())));
    writeBytes(dir / "g.nhdr",
               header("unsigned int", "endian: little\nencoding: gz\ndata file: g.raw.gz\n"));
    expectRamp(readField(dir / "g.nhdr"));

    std::string text;
    for (float v : ramp<float>()) text += std::to_string(v) + (text.size() % 3 ? "\n" : " ");
    writeBytes(dir / "a.nrrd", header("float", "encoding: ascii\n\n") + text);
    expectRamp(readField(dir / "a.nrrd"));

    auto check = [&](const std::string& type, const std::string& bytes) {
        writeBytes(dir / "t.nrrd", header(type, "endian: little\nencoding: raw\n\n") + bytes);
        SCOPED_TRACE(type);
        expectRamp(readField(dir / "t.nrrd"));
    };
    check("uchar", bytesOf(ramp<std::uint8_t>()));
    check("signed char", bytesOf(ramp<std::int8_t>()));
    check("uint16", bytesOf(ramp<std::uint16_t>()));
    check("int16_t", bytesOf(ramp<std::int16_t>()));
    check("uint32", bytesOf(ramp<std::uint32_t>()));
    check("int", bytesOf(ramp<std::int32_t>()));
    check("float", bytesOf(ramp<float>()));
    check("double", bytesOf(ramp<double>()));
}

TEST(IoNrrd, RejectsBadHeaders) {
    TempDir dir;
    std::string data = bytesOf(ramp<float>());
    auto expectBad = [&](const std::string& text, std::initializer_list<std::string> parts) {
        writeBytes(dir / "bad.nrrd", text);
        expectUdvrError([&] { readField(dir / "bad.nrrd"); }, parts);
    };
    expectBad("P6\n4 3\n", {"bad.nrrd", "not a NRRD file"});
    expectBad(header("float", "endian: little\nencoding: raw\ncolour: red\n\n") + data,
              {"bad.nrrd", "line 8", "unknown field 'colour'"});
    expectBad(header("int64", "endian: little\nencoding: raw\n\n") + data,
              {"unsupported type 'int64'"});
    expectBad(header("float", "endian: little\nencoding: bzip2\n\n") + data,
              {"unsupported encoding 'bzip2'"});
    expectBad(header("float", "endian: middle\nencoding: raw\n\n") + data, {"endian 'middle'"});
    expectBad(header("float", "encoding: raw\n\n") + data, {"no 'endian' field"});
    expectBad(
        "NRRD0004\ntype: float\ndimension: 3\nsizes: 4 3\nendian: little\n"
        "encoding: raw\n\n" +
            data,
        {"'sizes' must hold 3 values"});
    expectBad(
        "NRRD0004\ntype: float\ndimension: 4\nsizes: 1 4 3 2\nendian: little\n"
        "encoding: raw\n\n" +
            data,
        {"dimension 4 is not supported"});
    expectBad(header("float", "spacings: 1 0 1\nendian: little\nencoding: raw\n\n") + data,
              {"spacing along axis 1"});
    expectBad(header("float", "endian little\n"), {"line 6", "expected 'field: value'"});
    expectBad(header("float", "endian: little\nencoding: raw\n"), {"no 'data file' field"});
    expectBad(header("float", "endian: little\nencoding: raw\ndata file: gone.raw\n"),
              {"data file 'gone.raw' not found"});
}

TEST(IoNrrd, RejectsBadData) {
    TempDir dir;
    std::string data = bytesOf(ramp<float>());
    std::string h = header("float", "endian: little\nencoding: raw\n\n");
    writeBytes(dir / "short.nrrd", h + data.substr(0, 50));
    expectUdvrError([&] { readField(dir / "short.nrrd"); },
                    {"short.nrrd", "truncated", "expected 96 bytes", "found 50"});
    writeBytes(dir / "dims.nrrd", h + data + data);
    expectUdvrError([&] { readField(dir / "dims.nrrd"); }, {"dims.nrrd", "dims", "found 192"});

    std::string gz = gzip(data);
    std::string gzh = header("float", "endian: little\nencoding: gzip\n\n");
    writeBytes(dir / "gzshort.nrrd", gzh + gz.substr(0, gz.size() / 2));
    expectUdvrError([&] { readField(dir / "gzshort.nrrd"); },
                    {"gzshort.nrrd", "truncated gzip data", "expected 96 bytes"});
    writeBytes(dir / "gzlong.nrrd", gzh + gzip(data + data));
    expectUdvrError([&] { readField(dir / "gzlong.nrrd"); }, {"gzlong.nrrd", "dims"});
    writeBytes(dir / "gzbad.nrrd", gzh + "this is not gzip data at all");
    expectUdvrError([&] { readField(dir / "gzbad.nrrd"); }, {"gzbad.nrrd", "corrupt gzip"});

    std::vector<float> nan = ramp<float>();
    nan[4] = std::numeric_limits<float>::quiet_NaN();
    nan[5] = std::numeric_limits<float>::quiet_NaN();
    writeBytes(dir / "nan.nrrd", h + bytesOf(nan));
    expectUdvrError([&] { readField(dir / "nan.nrrd"); },
                    {"nan.nrrd", "2 NaN and 0 Inf", "(i,j,k) = (0,1,0)"});
}

// Found by fuzzing (fuzz/regressions/raw, nrrd): an infinite origin was accepted; dims whose
// product overflows size_t matched a short file (the grid then claimed 2^64 points); a header
// asking for 2^40 bytes made the reader reserve them.
TEST(IoRaw, RejectsNonFiniteOriginAndOverflowingDims) {
    TempDir dir;
    writeBytes(dir / "f.raw", bytesOf(ramp<float>()));
    FieldReadOptions o;
    o.raw.dims = {4, 3, 2};
    o.raw.origin[1] = -std::numeric_limits<double>::infinity();
    expectUdvrError([&] { readField(dir / "f.raw", o); }, {"f.raw", "origin must be finite"});
    o.raw.origin[1] = 0.0;
    o.raw.dims = {1 << 22, 1 << 22, 1 << 20};  // 2^64 points: 0 after wrapping
    writeBytes(dir / "empty.raw", "");
    expectUdvrError([&] { readField(dir / "empty.raw", o); },
                    {"empty.raw", "dims 4194304x4194304x1048576 are too large"});
    writeBytes(dir / "big.nrrd",
               "NRRD0004\ntype: float\ndimension: 3\nsizes: 1024 1024 1048576\nendian: "
               "little\nencoding: gzip\n\n" +
                   gzip("tiny"));
    expectUdvrError([&] { readField(dir / "big.nrrd"); }, {"big.nrrd", "truncated gzip data"});
}

// Notes are printed only once a read succeeded (an error stays one line on stderr), and raw
// bytes quoted from a file are escaped (UTF-8 output, one line).
TEST(IoNrrd, ErrorsAreOnePrintableLine) {
    TempDir dir;
    const std::string rotated =
        header("float",
               "space directions: (0,1,0) (1,0,0) (0,0,1)\nendian: little\nencoding: "
               "raw\n\n");
    writeBytes(dir / "cut.nrrd", rotated + bytesOf(ramp<float>()).substr(0, 48));
    ::testing::internal::CaptureStderr();
    expectUdvrError([&] { readField(dir / "cut.nrrd"); }, {"cut.nrrd", "truncated"});
    EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
    writeBytes(dir / "ok.nrrd", rotated + bytesOf(ramp<float>()));
    ::testing::internal::CaptureStderr();
    EXPECT_NO_THROW(readField(dir / "ok.nrrd"));
    EXPECT_NE(::testing::internal::GetCapturedStderr().find("space directions"), std::string::npos);

    writeBytes(dir / "bytes.nrrd", "NRRD0004\ntype: float\xff\xfe\x01\nsizes: 4 3 2\n\n");
    try {
        readField(dir / "bytes.nrrd");
        ADD_FAILURE() << "expected an error";
    } catch (const UdvrError& e) {
        EXPECT_NE(std::string(e.what()).find("'float\\xff\\xfe\\x01'"), std::string::npos)
            << e.what();
    }
}

TEST(IoField, UnknownExtensionAndMissingFile) {
    TempDir dir;
    writeBytes(dir / "f.xyz", "hello");
    expectUdvrError([&] { readField(dir / "f.xyz"); }, {"f.xyz", "unknown field format '.xyz'"});
    expectUdvrError([&] { readField(dir / "none.nhdr"); }, {"none.nhdr", "no such file"});
    ScalarField f;
    f.grid.dims = {1, 1, 1};
    f.values = {1.f};
    expectUdvrError([&] { writeField(dir / "out.png", f); }, {"out.png", "expected .vti or .nc"});
}

}  // namespace
}  // namespace udvr
