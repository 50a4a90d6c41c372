// PNG, NPY and PFM: round trips, files written independently here, and bad input.
#include "udvr/io/image.h"

#include <gtest/gtest.h>
#include <png.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>

#include "udvr/io/io_test_util.h"

namespace udvr {
namespace {

using testing::expectUdvrError;
using testing::readBytes;
using testing::TempDir;
using testing::writeBytes;

ImageRgba gradient(int w, int h) {
    ImageRgba img;
    img.width = w;
    img.height = h;
    img.rgba.resize(std::size_t(w) * std::size_t(h) * 4);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float* p = img.pixel(x, y);
            p[0] = float(x) / float(w);
            p[1] = float(y) / float(h);
            p[2] = 0.25f;
            p[3] = float(x + y) / float(w + h);
        }
    return img;
}

TEST(IoImage, PngRoundTripIsExactTo8Bits) {
    TempDir dir;
    ImageRgba img = gradient(7, 5);
    img.pixel(0, 0)[0] = 1.7f;   // clamped
    img.pixel(1, 0)[0] = -0.5f;  // clamped
    writePng(dir / "a.png", img);
    ImageRgba r = readImage(dir / "a.png");
    ASSERT_EQ(r.width, 7);
    ASSERT_EQ(r.height, 5);
    EXPECT_EQ(r.pixel(0, 0)[0], 1.0f);
    EXPECT_EQ(r.pixel(1, 0)[0], 0.0f);
    for (int y = 0; y < 5; ++y)
        for (int x = 2; x < 7; ++x)
            for (int c = 0; c < 4; ++c) {
                float want = std::round(img.pixel(x, y)[c] * 255.f) / 255.f;
                EXPECT_FLOAT_EQ(r.pixel(x, y)[c], want);
            }
}

/// A 16-bit gray PNG written with libpng directly: 3×2, top row 0, 0x8000, 0xffff.
void write16BitGray(const std::filesystem::path& path) {
    FILE* fp = std::fopen(path.c_str(), "wb");
    ASSERT_NE(fp, nullptr);
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png_create_info_struct(png);
    png_init_io(png, fp);
    png_set_IHDR(png, info, 3, 2, 16, PNG_COLOR_TYPE_GRAY, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    unsigned char rows[2][6] = {{0, 0, 0x80, 0, 0xff, 0xff}, {0x40, 0, 0x40, 0, 0x40, 0}};
    png_write_row(png, rows[0]);
    png_write_row(png, rows[1]);
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
    std::fclose(fp);
}

TEST(IoImage, PngReads16BitGray) {
    TempDir dir;
    write16BitGray(dir / "g.png");
    ImageRgba r = readPng(dir / "g.png");
    ASSERT_EQ(r.width, 3);
    ASSERT_EQ(r.height, 2);
    EXPECT_FLOAT_EQ(r.pixel(0, 0)[0], 0.f);
    EXPECT_FLOAT_EQ(r.pixel(1, 0)[1], 32768.f / 65535.f);
    EXPECT_FLOAT_EQ(r.pixel(2, 0)[2], 1.f);
    EXPECT_FLOAT_EQ(r.pixel(2, 1)[0], 16384.f / 65535.f);
    EXPECT_FLOAT_EQ(r.pixel(1, 1)[3], 1.f);  // opaque
}

TEST(IoImage, PngRejectsBadInput) {
    TempDir dir;
    writePng(dir / "a.png", gradient(40, 30));
    std::string bytes = readBytes(dir / "a.png");
    writeBytes(dir / "cut.png", bytes.substr(0, bytes.size() / 2));
    expectUdvrError([&] { readPng(dir / "cut.png"); }, {"cut.png", "cannot read PNG"});
    writeBytes(dir / "text.png", "not a png file");
    expectUdvrError([&] { readPng(dir / "text.png"); }, {"text.png", "not a PNG"});
    expectUdvrError([&] { readPng(dir / "none.png"); }, {"none.png", "no such file"});
    EXPECT_THROW(writePng(dir.path() / "nodir" / "a.png", gradient(2, 2)), UdvrError);
}

TEST(IoImage, NpyAndPfmRoundTrip) {
    TempDir dir;
    ImageRgba img = gradient(6, 4);
    img.pixel(5, 3)[0] = 12.5f;  // float images keep values beyond [0,1]
    writeFloatImage(dir / "a.npy", img);
    ImageRgba n = readImage(dir / "a.npy");
    EXPECT_EQ(n.width, 6);
    EXPECT_EQ(n.height, 4);
    EXPECT_EQ(n.rgba, img.rgba);
    std::string npy = readBytes(dir / "a.npy");
    EXPECT_EQ(npy.substr(0, 6), "\x93NUMPY");
    EXPECT_NE(npy.find("'shape': (4, 6, 4)"), std::string::npos);
    EXPECT_EQ((npy.size() - 6 * 4 * 4 * 4) % 64, 0u);  // header aligned to 64 bytes

    writeFloatImage(dir / "a.pfm", img);
    ImageRgba p = readImage(dir / "a.pfm");
    ASSERT_EQ(p.width, 6);
    ASSERT_EQ(p.height, 4);
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 6; ++x) {
            for (int c = 0; c < 3; ++c) EXPECT_EQ(p.pixel(x, y)[c], img.pixel(x, y)[c]);
            EXPECT_EQ(p.pixel(x, y)[3], 1.f);  // PFM has no alpha
        }
    // The first row in the file is the bottom row of the image.
    std::string pfm = readBytes(dir / "a.pfm");
    EXPECT_EQ(pfm.substr(0, 11), "PF\n6 4\n-1.0");
    float first;
    std::memcpy(&first, pfm.data() + pfm.find("-1.0\n") + 5 + 4, 4);  // green of pixel (0,3)
    EXPECT_EQ(first, img.pixel(0, 3)[1]);
    EXPECT_THROW(writeFloatImage(dir / "a.exr", img), UdvrError);
}

/// NPY version 1.0, h×w×3 float64, written by hand.
std::string npyRgbDouble(int h, int w, const std::vector<double>& values) {
    std::string dict = "{'descr': '<f8', 'fortran_order': False, 'shape': (" + std::to_string(h) +
                       ", " + std::to_string(w) + ", 3), }";
    while ((10 + dict.size() + 1) % 16 != 0) dict += ' ';
    dict += '\n';
    std::string out("\x93NUMPY\x01\x00", 8);
    out.push_back(static_cast<char>(dict.size() & 0xff));
    out.push_back(static_cast<char>(dict.size() >> 8));
    return out + dict + testing::bytesOf(values);
}

TEST(IoImage, ReadsRgbDoubleNpyAndBigEndianPfm) {
    TempDir dir;
    std::vector<double> v;
    for (int i = 0; i < 2 * 3 * 3; ++i) v.push_back(0.1 * i);
    writeBytes(dir / "rgb.npy", npyRgbDouble(2, 3, v));
    ImageRgba r = readFloatImage(dir / "rgb.npy");
    ASSERT_EQ(r.width, 3);
    ASSERT_EQ(r.height, 2);
    EXPECT_FLOAT_EQ(r.pixel(2, 1)[2], 1.7f);
    EXPECT_EQ(r.pixel(2, 1)[3], 1.f);

    // 1×2 gray "Pf", big endian (positive scale): top row value 2, bottom row value 0.5.
    std::string pf = "Pf\n1 2\n1.0\n";
    const unsigned char half[4] = {0x3f, 0, 0, 0}, two[4] = {0x40, 0, 0, 0};
    pf.append(reinterpret_cast<const char*>(half), 4);  // file row 0 = bottom
    pf.append(reinterpret_cast<const char*>(two), 4);
    writeBytes(dir / "g.pfm", pf);
    ImageRgba g = readFloatImage(dir / "g.pfm");
    EXPECT_EQ(g.pixel(0, 0)[0], 2.f);
    EXPECT_EQ(g.pixel(0, 1)[2], 0.5f);
}

TEST(IoImage, FloatImagesRejectBadInput) {
    TempDir dir;
    writeFloatImage(dir / "a.npy", gradient(4, 4));
    std::string npy = readBytes(dir / "a.npy");
    writeBytes(dir / "cut.npy", npy.substr(0, npy.size() - 8));
    expectUdvrError([&] { readFloatImage(dir / "cut.npy"); },
                    {"cut.npy", "truncated", "expected 256 bytes", "found 248"});
    std::string i32 = npy;
    i32.replace(i32.find("<f4"), 3, "<i4");
    writeBytes(dir / "int.npy", i32);
    expectUdvrError([&] { readFloatImage(dir / "int.npy"); }, {"int.npy", "'<i4'"});
    std::string twoD = npy;
    twoD.replace(twoD.find("(4, 4, 4)"), 9, "(4, 16)  ");
    writeBytes(dir / "shape.npy", twoD);
    expectUdvrError([&] { readFloatImage(dir / "shape.npy"); }, {"shape.npy", "shape"});
    ImageRgba nan = gradient(4, 4);
    nan.pixel(2, 3)[1] = std::numeric_limits<float>::quiet_NaN();
    writeFloatImage(dir / "nan.npy", nan);
    expectUdvrError([&] { readFloatImage(dir / "nan.npy"); }, {"nan.npy", "1 NaN", "(2,3)"});

    writeFloatImage(dir / "a.pfm", gradient(4, 4));
    std::string pfm = readBytes(dir / "a.pfm");
    writeBytes(dir / "cut.pfm", pfm.substr(0, pfm.size() - 4));
    expectUdvrError([&] { readFloatImage(dir / "cut.pfm"); }, {"cut.pfm", "truncated"});
    writeBytes(dir / "p6.pfm", "P6\n4 4\n255\n");
    expectUdvrError([&] { readFloatImage(dir / "p6.pfm"); }, {"p6.pfm", "not a PFM"});
    expectUdvrError([&] { readImage(dir / "a.tif"); }, {"a.tif", "unknown"});
}

}  // namespace
}  // namespace udvr
