#include "udvr/io/transfer_function_2d_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "udvr/io/io_test_util.h"

namespace udvr {
namespace {

using testing::bytesOf;
using testing::expectUdvrError;
using testing::fileCount;
using testing::TempDir;
using testing::writeBytes;

// A W×H raster with distinct values in [0, 1]: channel ch of point (i, j).
TransferFunction2D sampleRaster(int w, int h, std::array<double, 4> domain) {
    TransferFunction2D tf;
    tf.width = w;
    tf.height = h;
    tf.x0 = domain[0];
    tf.x1 = domain[1];
    tf.y0 = domain[2];
    tf.y1 = domain[3];
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i)
            for (int ch = 0; ch < 4; ++ch)
                tf.rgba.push_back(static_cast<float>((i + 7 * j + 0.37 * ch) / (w + 7 * h + 2.0)));
    tf.validate();
    return tf;
}

void expectSame(const TransferFunction2D& a, const TransferFunction2D& b) {
    EXPECT_EQ(a.width, b.width);
    EXPECT_EQ(a.height, b.height);
    EXPECT_EQ(a.x0, b.x0);
    EXPECT_EQ(a.x1, b.x1);
    EXPECT_EQ(a.y0, b.y0);
    EXPECT_EQ(a.y1, b.y1);
    EXPECT_EQ(a.rgba, b.rgba);
}

// A .npy with a hand-written header (independent of the writer under test).
std::string npy(const std::string& descr, const std::string& shape, const std::string& data,
                int major = 1, const std::string& fortran = "False") {
    std::string dict =
        "{'descr': '" + descr + "', 'fortran_order': " + fortran + ", 'shape': " + shape + ", }";
    const std::size_t prefix = major == 1 ? 10 : 12;
    dict.append((64 - (prefix + dict.size() + 1) % 64) % 64, ' ');
    dict += '\n';
    std::string out("\x93NUMPY", 6);
    out.push_back(static_cast<char>(major));
    out.push_back('\0');
    for (std::size_t b = 0; b < prefix - 8; ++b)
        out.push_back(static_cast<char>((dict.size() >> (8 * b)) & 0xFF));
    return out + dict + data;
}

constexpr std::array<double, 4> kDomain{-7.0, 35.0, 0.0, 60.0};

Tf2ReadOptions withDomain(std::array<double, 4> d = kDomain) {
    Tf2ReadOptions o;
    o.domain = d;
    return o;
}

// ---- widget JSON ----------------------------------------------------------------------------

TEST(Tf2Io, WidgetJsonRasterisesWithDefaultsAndOverrides) {
    const std::string json = R"({
      "name": "demo", "comment": "two widgets",
      "domain": [0, 10, 0, 20],
      "widgets": [
        {"type": "box", "x": [2, 4], "y": [0, 20], "rgba": [1, 0, 0, 0.5], "name": "b"},
        {"type": "triangle", "apex": [7, 0], "top": 20, "width": 4, "falloff": "flat",
         "rgba": [0, 1, 0, 1]},
        {"type": "ellipse", "center": [5, 10], "sigma": [1, 2], "angle": 45, "cutoff": 2,
         "rgba": [0, 0, 1, 0.3]},
        {"type": "band", "points": [[0, 0], [10, 20]], "half_width": [0.5, 1],
         "profile": "tent", "rgba": [1, 1, 1, 0.2]}
      ]})";
    const TransferFunction2D tf = transferFunction2DFromWidgets(json, "w.json");
    EXPECT_EQ(tf.width, kDefaultTf2Resolution);
    EXPECT_EQ(tf.height, kDefaultTf2Resolution);
    EXPECT_EQ(tf.x1, 10.0);
    EXPECT_EQ(tf.y1, 20.0);
    const Tf2WidgetFile file = parseTf2Widgets(json, "w.json");
    ASSERT_EQ(file.widgets.size(), 4u);
    EXPECT_TRUE(std::get<Tf2Triangle>(file.widgets[1].shape).flat);
    EXPECT_EQ(std::get<Tf2Ellipse>(file.widgets[2].shape).angleDeg, 45.0);
    EXPECT_EQ(std::get<Tf2Ellipse>(file.widgets[2].shape).cutoff, 2.0);
    EXPECT_TRUE(std::get<Tf2Band>(file.widgets[3].shape).tent);
    EXPECT_EQ(file.widgets[0].rgba[3], 0.5);

    // The options' domain and resolution win over the file's.
    Tf2ReadOptions o;
    o.domain = std::array<double, 4>{0, 10, 0, 10};
    o.resolution = std::array<int, 2>{11, 6};
    const TransferFunction2D small = transferFunction2DFromWidgets(json, "w.json", o);
    EXPECT_EQ(small.width, 11);
    EXPECT_EQ(small.height, 6);
    EXPECT_EQ(small.y1, 10.0);
    // Point (3, 0) is x = 3, y = 0: inside the box only → red at 0.5 …
    EXPECT_FLOAT_EQ(small.point(3, 0)[3], 0.5f);
    EXPECT_FLOAT_EQ(small.point(3, 0)[0], 1.f);
    // … point (7, 5) = (7, 10) is on the flat triangle's centre line: α = 1.
    EXPECT_FLOAT_EQ(small.point(7, 5)[3], 1.f);

    // The file's resolution when the options give none.
    const TransferFunction2D fileRes = transferFunction2DFromWidgets(
        R"({"domain": [0, 1, 0, 1], "resolution": [3, 2], "widgets": []})", "r.json");
    EXPECT_EQ(fileRes.width, 3);
    EXPECT_EQ(fileRes.height, 2);
    // A domain from the options alone is enough.
    const TransferFunction2D noDomain =
        transferFunction2DFromWidgets(R"({"widgets": []})", "n.json", withDomain());
    EXPECT_EQ(noDomain.x0, -7.0);
}

TEST(Tf2Io, WidgetJsonErrorsNameTheWidgetAndKey) {
    const auto bad = [](const std::string& widgets, std::initializer_list<std::string> parts,
                        const std::string& top = R"("domain": [0, 1, 0, 1])") {
        expectUdvrError(
            [&] {
                transferFunction2DFromWidgets("{" + top + ", \"widgets\": [" + widgets + "]}",
                                              "bad.json");
            },
            parts);
    };
    const std::string box = R"({"type": "box", "x": [0, 1], "y": [0, 1], "rgba": [1, 1, 1, 1]})";
    bad(box + R"(, {"type": "blob", "rgba": [1, 1, 1, 1]})",
        {"bad.json", "widget 1", "unknown type \"blob\"", "box, triangle, ellipse or band"});
    bad(R"({"type": "box", "x": [0, 1], "y": [0, 1], "rgba": [1, 1, 1, 1], "z": 3})",
        {"bad.json", "widget 0 (box)", "unknown key 'z'"});
    bad(R"({"type": "box", "x": [0, 1], "rgba": [1, 1, 1, 1]})",
        {"widget 0 (box)", "missing key 'y'"});
    bad(R"({"type": "box", "x": [1, 0], "y": [0, 1], "rgba": [1, 1, 1, 1]})",
        {"widget 0 (box)", "'x' must be [low, high]"});
    bad(R"({"x": [1, 0], "y": [0, 1], "rgba": [1, 1, 1, 1]})", {"widget 0", "missing key 'type'"});
    bad(R"({"type": "box", "x": [0, 1], "y": [0, 1], "rgba": [1, 1, 1.5, 1]})",
        {"widget 0 (box)", "'rgba'", "[0, 1]"});
    bad(R"({"type": "box", "x": [0, 1], "y": [0, 1], "rgba": [1, 1, 1]})",
        {"widget 0 (box)", "'rgba' must be an array of 4 numbers"});
    bad(R"({"type": "box", "x": [0, "a"], "y": [0, 1], "rgba": [1, 1, 1, 1]})",
        {"widget 0 (box)", "'x[1]' must be a number"});
    bad(R"({"type": "triangle", "apex": [0, 0], "top": 0, "width": 1, "rgba": [1, 1, 1, 1]})",
        {"widget 0 (triangle)", "'top'"});
    bad(R"({"type": "triangle", "apex": [0, 0], "top": 1, "width": -1, "rgba": [1, 1, 1, 1]})",
        {"widget 0 (triangle)", "'width' must be > 0"});
    bad(R"({"type": "triangle", "apex": [0, 0], "top": 1, "width": 1, "falloff": "soft",
            "rgba": [1, 1, 1, 1]})",
        {"widget 0 (triangle)", "'falloff'"});
    bad(R"({"type": "ellipse", "center": [0, 0], "sigma": [0, 1], "rgba": [1, 1, 1, 1]})",
        {"widget 0 (ellipse)", "'sigma'"});
    bad(R"({"type": "ellipse", "center": [0, 0], "sigma": [1, 1], "cutoff": 0,
            "rgba": [1, 1, 1, 1]})",
        {"widget 0 (ellipse)", "'cutoff' must be > 0"});
    bad(R"({"type": "band", "points": [], "half_width": [1, 1], "rgba": [1, 1, 1, 1]})",
        {"widget 0 (band)", "'points'"});
    bad(R"({"type": "band", "points": [[0, 0], [1]], "half_width": [1, 1], "rgba": [1, 1, 1, 1]})",
        {"widget 0 (band)", "'points[1]'"});
    bad(R"({"type": "band", "points": [[0, 0]], "half_width": [1, 0], "rgba": [1, 1, 1, 1]})",
        {"widget 0 (band)", "'half_width'"});
    bad(R"({"type": "band", "points": [[0, 0]], "half_width": [1, 1], "profile": "gauss",
            "rgba": [1, 1, 1, 1]})",
        {"widget 0 (band)", "'profile'"});
    bad("42", {"widget 0", "expected an object"});
    // Top level.
    bad(box, {"bad.json", "empty domain"}, R"("domain": [0, 1, 1, 1])");
    bad(box, {"bad.json", "'domain' must be an array of 4 numbers"}, R"("domain": [0, 1, 1])");
    bad(box, {"bad.json", "'resolution'", "out of range"},
        R"("domain": [0, 1, 0, 1], "resolution": [1, 4])");
    bad(box, {"bad.json", "'resolution'", "out of range"},
        R"("domain": [0, 1, 0, 1], "resolution": [8193, 4])");
    bad(box, {"bad.json", "'resolution' must be [W, H]"},
        R"("domain": [0, 1, 0, 1], "resolution": [2.5, 4])");
    bad(box, {"bad.json", "unknown key 'colour'"}, R"("domain": [0, 1, 0, 1], "colour": 1)");
    bad(box, {"bad.json", "missing key 'domain'"}, R"("name": "x")");
    expectUdvrError([] { transferFunction2DFromWidgets("{\"domain\": [0, 1, 0, 1]}", "m.json"); },
                    {"m.json", "missing key 'widgets'"});
    expectUdvrError([] { transferFunction2DFromWidgets("{\"widgets\": [", "j.json"); },
                    {"j.json", "not valid JSON"});
    expectUdvrError([] { transferFunction2DFromWidgets("[1, 2]", "j.json"); },
                    {"j.json", "expected an object"});
    // Numbers too large for a double are not finite.
    expectUdvrError(
        [] {
            transferFunction2DFromWidgets(R"({"domain": [0, 1e999, 0, 1], "widgets": []})",
                                          "i.json");
        },
        {"i.json"});
    // Options are checked too.
    Tf2ReadOptions o;
    o.resolution = std::array<int, 2>{2, 9000};
    expectUdvrError(
        [&] {
            transferFunction2DFromWidgets(R"({"domain": [0, 1, 0, 1], "widgets": []})", "o.json",
                                          o);
        },
        {"o.json", "resolution 2x9000 out of range"});
    expectUdvrError(
        [] {
            transferFunction2DFromWidgets(R"({"widgets": []})", "d.json",
                                          withDomain({0, 1, std::nan(""), 2}));
        },
        {"d.json", "finite"});
}

TEST(Tf2Io, ReadsJsonByExtensionCaseInsensitive) {
    TempDir dir;
    writeBytes(dir / "w.JSON", R"({"domain": [0, 1, 0, 1], "resolution": [4, 3], "widgets": []})");
    const TransferFunction2D tf = readTransferFunction2D(dir / "w.JSON");
    EXPECT_EQ(tf.width, 4);
    expectUdvrError([&] { readTransferFunction2D(dir / "w.txt"); },
                    {"w.txt", "unknown extension '.txt'", ".vti, .npy or .json"});
    expectUdvrError([&] { readTransferFunction2D(dir / "missing.json"); },
                    {"missing.json", "no such file"});
}

// ---- .vti rasters ---------------------------------------------------------------------------

TEST(Tf2Io, VtiRoundTripIsExact) {
    TempDir dir;
    const TransferFunction2D tf = sampleRaster(5, 3, {-1.3, 2.7, 0.1, 7.9});
    writeTransferFunction2DVti(dir / "t.vti", tf);
    EXPECT_EQ(fileCount(dir.path()), 1u);  // no temporary left behind
    expectSame(readTransferFunction2D(dir / "t.vti"), tf);
    writeTransferFunction2D(dir / "u.VTI", tf);
    expectSame(readTransferFunction2D(dir / "u.VTI"), tf);
    expectUdvrError([&] { readTransferFunction2D(dir / "t.vti", withDomain()); },
                    {"t.vti", "carries its domain"});
    Tf2ReadOptions res;
    res.resolution = std::array<int, 2>{4, 4};
    expectUdvrError([&] { readTransferFunction2D(dir / "t.vti", res); },
                    {"t.vti", "widget (.json) files only"});
    expectUdvrError([&] { writeTransferFunction2D(dir / "t.png", tf); }, {"t.png", ".vti or .npy"});
}

// A VTK XML ImageData file in ASCII, as ParaView or VTK would write one by hand.
std::string asciiVti(const std::string& extent, const std::string& origin,
                     const std::string& spacing, const std::string& arrays,
                     const std::string& scalars = "") {
    return "<?xml version=\"1.0\"?>\n"
           "<VTKFile type=\"ImageData\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
           "<ImageData WholeExtent=\"" +
           extent + "\" Origin=\"" + origin + "\" Spacing=\"" + spacing + "\">\n<Piece Extent=\"" +
           extent + "\">\n<PointData" + (scalars.empty() ? "" : " Scalars=\"" + scalars + "\"") +
           ">\n" + arrays + "</PointData>\n<CellData/>\n</Piece>\n</ImageData>\n</VTKFile>\n";
}

std::string dataArray(const std::string& type, const std::string& name, int components, int tuples,
                      double scale = 0.01) {
    std::string values;
    const bool integer = type.find("Int") != std::string::npos;
    for (int k = 0; k < tuples * components; ++k)
        values += (integer ? std::to_string(k) : std::to_string(k * scale)) + " ";
    return "<DataArray type=\"" + type + "\" Name=\"" + name + "\" NumberOfComponents=\"" +
           std::to_string(components) + "\" format=\"ascii\">" + values + "</DataArray>\n";
}

TEST(Tf2Io, VtiFromOtherToolsUsesOriginSpacingAndTheRgbaArray) {
    TempDir dir;
    // 3×2 points, x along i from -1 by 0.5, y along j from 10 by 4 (extent starting at 2).
    // A scalar array is active; the TF is the first 4-component array.
    writeBytes(dir / "a.vti",
               asciiVti("0 2 2 3 0 0", "-1 2 0", "0.5 4 1",
                        dataArray("Float32", "density", 1, 6) + dataArray("Float64", "rgba", 4, 6) +
                            dataArray("Float32", "other", 4, 6, 0.001),
                        "density"));
    const TransferFunction2D tf = readTransferFunction2D(dir / "a.vti");
    EXPECT_EQ(tf.width, 3);
    EXPECT_EQ(tf.height, 2);
    EXPECT_DOUBLE_EQ(tf.x0, -1.0);
    EXPECT_DOUBLE_EQ(tf.x1, 0.0);
    EXPECT_DOUBLE_EQ(tf.y0, 10.0);  // origin 2 + extent start 2 × spacing 4
    EXPECT_DOUBLE_EQ(tf.y1, 14.0);
    // Point (i, j) is tuple j·W + i: (1, 1) is tuple 4, channel 2 is value 18 → 0.18.
    EXPECT_FLOAT_EQ(tf.point(1, 1)[2], 0.18f);
    EXPECT_FLOAT_EQ(tf.point(2, 0)[3], 0.11f);

    // The active scalars win when they are RGBA.
    writeBytes(dir / "b.vti", asciiVti("0 2 0 1 0 0", "0 0 0", "1 1 1",
                                       dataArray("Float32", "rgba", 4, 6) +
                                           dataArray("Float32", "other", 4, 6, 0.001),
                                       "other"));
    EXPECT_FLOAT_EQ(readTransferFunction2D(dir / "b.vti").point(1, 1)[2], 0.018f);
}

TEST(Tf2Io, BadVtiGivesOneLineErrors) {
    TempDir dir;
    writeBytes(dir / "z.vti",
               asciiVti("0 1 0 1 0 1", "0 0 0", "1 1 1", dataArray("Float32", "rgba", 4, 8)));
    expectUdvrError([&] { readTransferFunction2D(dir / "z.vti"); },
                    {"z.vti", "W x H x 1", "2x2x2"});
    writeBytes(dir / "s.vti",
               asciiVti("0 2 0 1 0 0", "0 0 0", "1 1 1", dataArray("Float32", "v", 1, 6)));
    expectUdvrError([&] { readTransferFunction2D(dir / "s.vti"); },
                    {"s.vti", "no 4-component", "v"});
    writeBytes(dir / "u.vti",
               asciiVti("0 2 0 1 0 0", "0 0 0", "1 1 1", dataArray("UInt8", "rgba", 4, 6, 1.0)));
    expectUdvrError([&] { readTransferFunction2D(dir / "u.vti"); },
                    {"u.vti", "expected float or double"});
    writeBytes(dir / "r.vti",
               asciiVti("0 2 0 1 0 0", "0 0 0", "1 1 1", dataArray("Float32", "rgba", 4, 6, 0.1)));
    expectUdvrError([&] { readTransferFunction2D(dir / "r.vti"); }, {"r.vti", "[0,1]"});
    writeBytes(dir / "n.vti", asciiVti("0 2 0 1 0 0", "0 0 0", "1 1 1",
                                       "<DataArray type=\"Float32\" Name=\"rgba\" "
                                       "NumberOfComponents=\"4\" format=\"ascii\">0 0 0 nan "
                                       "0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0</DataArray>\n"));
    expectUdvrError([&] { readTransferFunction2D(dir / "n.vti"); }, {"n.vti"});
    writeBytes(dir / "g.vti", "<?xml version=\"1.0\"?>\n<VTKFile type=\"ImageData\"");
    expectUdvrError([&] { readTransferFunction2D(dir / "g.vti"); }, {"g.vti"});
}

// ---- .npy rasters ---------------------------------------------------------------------------

TEST(Tf2Io, NpyRoundTripIsExact) {
    TempDir dir;
    const TransferFunction2D tf = sampleRaster(4, 6, kDomain);
    writeTransferFunction2DNpy(dir / "t.npy", tf);
    EXPECT_EQ(fileCount(dir.path()), 1u);
    expectSame(readTransferFunction2D(dir / "t.npy", withDomain()), tf);
    expectUdvrError([&] { readTransferFunction2D(dir / "t.npy"); },
                    {"t.npy", "carries no domain", "--tf2-domain"});
    expectUdvrError(
        [&] {
            readTransferFunction2D(dir / "t.npy", withDomain({1, 0, 0, 1}));
        },
        {"t.npy", "empty domain"});
}

TEST(Tf2Io, HandBuiltNpyInEveryDtype) {
    TempDir dir;
    // Shape (2, 3, 4): row j, column i, channel ch holds (j·3 + i)·4 + ch, over 24.
    std::vector<float> f4;
    std::vector<double> f8;
    std::vector<std::uint8_t> u1;
    for (int k = 0; k < 24; ++k) {
        f4.push_back(static_cast<float>(k / 24.0));
        f8.push_back(k / 24.0);
        u1.push_back(static_cast<std::uint8_t>(k * 10));
    }
    writeBytes(dir / "f4.npy", npy("<f4", "(2, 3, 4)", bytesOf(f4)));
    writeBytes(dir / "f8.npy", npy("<f8", "(2, 3, 4)", bytesOf(f8)));
    writeBytes(dir / "u1.npy", npy("|u1", "(2, 3, 4)", bytesOf(u1)));
    writeBytes(dir / "v2.npy", npy("<f4", "(2, 3, 4)", bytesOf(f4), 2));
    for (const char* name : {"f4.npy", "f8.npy", "v2.npy"}) {
        const TransferFunction2D tf = readTransferFunction2D(dir / name, withDomain());
        EXPECT_EQ(tf.width, 3) << name;
        EXPECT_EQ(tf.height, 2) << name;
        // Row 1 is the larger y; point (2, 1) is element (1·3 + 2)·4.
        EXPECT_FLOAT_EQ(tf.point(2, 1)[1], static_cast<float>(21 / 24.0)) << name;
        EXPECT_FLOAT_EQ(tf.point(0, 0)[3], static_cast<float>(3 / 24.0)) << name;
    }
    const TransferFunction2D bytes = readTransferFunction2D(dir / "u1.npy", withDomain());
    EXPECT_FLOAT_EQ(bytes.point(2, 1)[1], static_cast<float>(210 / 255.0));  // scaled by 1/255
    EXPECT_FLOAT_EQ(bytes.point(0, 0)[3], static_cast<float>(30 / 255.0));
    EXPECT_EQ(bytes.y1, 60.0);
}

TEST(Tf2Io, BadNpyGivesOneLineErrors) {
    TempDir dir;
    const std::vector<float> ok(24, 0.5f);
    const auto fails = [&](const std::string& name, const std::string& bytes,
                           std::initializer_list<std::string> parts) {
        writeBytes(dir / name, bytes);
        expectUdvrError([&] { readTransferFunction2D(dir / name, withDomain()); }, parts);
        expectUdvrError([&] { readTransferFunction2D(dir / name, withDomain()); }, {name});
    };
    fails("trunc.npy", npy("<f4", "(2, 3, 4)", bytesOf(ok).substr(0, 90)),
          {"truncated NPY data", "expected 96 bytes, found 90"});
    fails("long.npy", npy("<f4", "(2, 3, 4)", bytesOf(ok) + "xxxx"), {"does not match the data"});
    fails("rgb.npy", npy("<f4", "(2, 3, 3)", bytesOf(std::vector<float>(18, 0.5f))),
          {"shape (2, 3, 3)", "(H, W, 4)"});
    fails("flat.npy", npy("<f4", "(24,)", bytesOf(ok)), {"shape (24)"});
    fails("row.npy", npy("<f4", "(1, 6, 4)", bytesOf(ok)), {"shape (1, 6, 4)"});
    fails("fortran.npy", npy("<f4", "(2, 3, 4)", bytesOf(ok), 1, "True"), {"fortran_order"});
    fails("big.npy", npy(">f4", "(2, 3, 4)", bytesOf(ok)), {"'>f4'", "big-endian"});
    fails("int.npy", npy("<i4", "(2, 3, 4)", bytesOf(std::vector<std::int32_t>(24, 0))),
          {"'<i4' unsupported"});
    fails("magic.npy", "NUMPY" + bytesOf(ok), {"bad magic"});
    std::vector<float> nan = ok;
    nan[13] = std::numeric_limits<float>::quiet_NaN();
    fails("nan.npy", npy("<f4", "(2, 3, 4)", bytesOf(nan)),
          {"non-finite", "row 1, column 0, channel 1"});
    std::vector<float> big = ok;
    big[5] = 1.5f;
    fails("range.npy", npy("<f4", "(2, 3, 4)", bytesOf(big)), {"[0,1]"});
}

}  // namespace
}  // namespace udvr
