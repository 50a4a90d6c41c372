#include "udvr/eval/figure.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "udvr/io/image.h"

namespace udvr {
namespace {

namespace fs = std::filesystem;

/// An image whose pixel (x, y) holds bytes that identify it: r = x, g = y, b = tag.
ImageRgba patternImage(int w, int h, int tag) {
    ImageRgba img;
    img.width = w;
    img.height = h;
    img.rgba.resize(static_cast<std::size_t>(w) * h * 4);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float* p = img.pixel(x, y);
            p[0] = static_cast<float>(x) / 255.f;
            p[1] = static_cast<float>(y) / 255.f;
            p[2] = static_cast<float>(tag) / 255.f;
            p[3] = 0.25f;  // alpha is ignored: renders are already composited
        }
    return img;
}

int byteOf(float v) { return static_cast<int>(std::lround(v * 255.f)); }

/// Width and height from a PNG's IHDR chunk.
std::pair<int, int> pngSize(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_GE(bytes.size(), 24u);
    EXPECT_EQ(bytes.substr(1, 3), "PNG");
    auto be32 = [&](std::size_t o) {
        return (static_cast<int>(static_cast<unsigned char>(bytes[o])) << 24) |
               (static_cast<int>(static_cast<unsigned char>(bytes[o + 1])) << 16) |
               (static_cast<int>(static_cast<unsigned char>(bytes[o + 2])) << 8) |
               static_cast<int>(static_cast<unsigned char>(bytes[o + 3]));
    };
    return {be32(16), be32(20)};
}

fs::path tempDir(const std::string& name) {
    const fs::path dir =
        fs::temp_directory_path() / ("udvr_figure_test_" + name + "_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    return dir;
}

TEST(FigurePanel, EachRowIsAsTallAsItsTallestImage) {
    // A tall plot in the first row must not space out the rows of small images below it.
    FigurePanel panel;
    panel.columns = 2;
    panel.cells.push_back({patternImage(20, 60, 1), {"tall"}});
    panel.cells.push_back({patternImage(20, 10, 2), {"small"}});
    for (int k = 0; k < 2; ++k) panel.cells.push_back({patternImage(20, 10, 3), {"small"}});
    const PanelLayout l = panelLayout(panel);
    EXPECT_EQ(l.cellHeight, 60);
    ASSERT_EQ(l.rowHeight, (std::vector<int>{60, 10}));
    const int step = l.imageOrigin[2][1] - l.imageOrigin[0][1];  // row 0's band and a gap
    EXPECT_GT(step, 60 + l.captionHeight);
    EXPECT_LT(step, 60 + l.captionHeight + 20);
    EXPECT_EQ(l.imageOrigin[3][1], l.imageOrigin[2][1]);
    // The panel ends one small row (and its caption) after the second row's top.
    EXPECT_LT(l.height, l.imageOrigin[2][1] + 10 + l.captionHeight + 20);
    EXPECT_EQ(renderPanel(panel).height, l.height);
}

TEST(FigurePanel, PastesImagesByteExactWhereTheLayoutSays) {
    FigurePanel panel;
    panel.title = "a title";
    panel.columns = 2;
    panel.cells.push_back({patternImage(20, 16, 7), {"first", "RMSE 0.0123"}});
    panel.cells.push_back({patternImage(12, 10, 99), {"second"}});
    panel.cells.push_back({patternImage(20, 16, 200), {"third"}});
    const PanelLayout l = panelLayout(panel);
    ASSERT_EQ(l.imageOrigin.size(), 3u);
    EXPECT_EQ(l.cellWidth, 20);
    EXPECT_EQ(l.cellHeight, 16);
    const ImageRgba out = renderPanel(panel);
    ASSERT_EQ(out.width, l.width);
    ASSERT_EQ(out.height, l.height);
    for (std::size_t c = 0; c < panel.cells.size(); ++c) {
        const ImageRgba& img = panel.cells[c].image;
        for (int y = 0; y < img.height; ++y)
            for (int x = 0; x < img.width; ++x) {
                const float* p = out.pixel(l.imageOrigin[c][0] + x, l.imageOrigin[c][1] + y);
                ASSERT_EQ(byteOf(p[0]), x);
                ASSERT_EQ(byteOf(p[1]), y);
                ASSERT_EQ(byteOf(p[2]), byteOf(img.pixel(x, y)[2]));
                ASSERT_EQ(p[3], 1.f);
            }
    }
    // Cells do not overlap; the second (narrower) image is centred in its cell.
    EXPECT_GE(l.imageOrigin[1][0], l.imageOrigin[0][0] + 20);
    EXPECT_EQ(l.imageOrigin[2][0], l.imageOrigin[0][0]);
    EXPECT_GT(l.imageOrigin[2][1], l.imageOrigin[0][1] + 16);
    // The corner is background white, and some caption text was drawn (dark pixels).
    EXPECT_EQ(byteOf(out.pixel(0, 0)[0]), 255);
    int dark = 0;
    for (int y = l.imageOrigin[0][1] + 16; y < l.imageOrigin[2][1]; ++y)
        for (int x = 0; x < out.width; ++x) dark += out.pixel(x, y)[0] < 0.5f;
    EXPECT_GT(dark, 10);

    // Written as a PNG of the same size with the same bytes.
    const fs::path dir = tempDir("panel");
    writeFigurePng(dir / "panel.png", out);
    EXPECT_EQ(pngSize(dir / "panel.png"), std::make_pair(out.width, out.height));
    const ImageRgba back = readPng(dir / "panel.png");
    ASSERT_EQ(back.width, out.width);
    ASSERT_EQ(back.height, out.height);
    const float* p = back.pixel(l.imageOrigin[0][0] + 5, l.imageOrigin[0][1] + 3);
    EXPECT_EQ(byteOf(p[0]), 5);
    EXPECT_EQ(byteOf(p[1]), 3);
    EXPECT_EQ(byteOf(p[2]), 7);
    fs::remove_all(dir);
}

TEST(FigurePanel, EmptyCellsStayBlank) {
    FigurePanel panel;
    panel.columns = 3;
    panel.cells.push_back({patternImage(8, 8, 1), {}});
    panel.cells.push_back({});
    panel.cells.push_back({patternImage(8, 8, 2), {}});
    const PanelLayout l = panelLayout(panel);
    const ImageRgba out = renderPanel(panel);
    const float* p = out.pixel(l.imageOrigin[1][0] + 4, l.imageOrigin[1][1] + 4);
    EXPECT_EQ(byteOf(p[0]), 255);
    EXPECT_EQ(byteOf(p[1]), 255);
    EXPECT_EQ(byteOf(p[2]), 255);
}

TEST(LinePlot, SizeBackgroundAndSeriesColour) {
    PlotAxes a;
    a.title = "empirical";
    a.xLabel = "members";
    a.yLabel = "RMSE";
    a.logX = true;
    a.series.push_back({"q=2", {5, 10, 20, 50}, {0.03, 0.02, 0.015, 0.01}, {1.0, 0.0, 0.0}, false});
    a.series.push_back({"q=8", {5, 10, 20, 50}, {0.04, NAN, 0.012, 0.008}, {0.0, 0.0, 1.0}, true});
    PlotAxes b = a;
    b.title = "kde";
    const ImageRgba img = renderLinePlots({a, b}, 640, 300);
    ASSERT_EQ(img.width, 640);
    ASSERT_EQ(img.height, 300);
    EXPECT_EQ(byteOf(img.pixel(0, 0)[0]), 255);
    int red = 0, blue = 0;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const float* p = img.pixel(x, y);
            red += byteOf(p[0]) == 255 && byteOf(p[1]) == 0 && byteOf(p[2]) == 0;
            blue += byteOf(p[0]) == 0 && byteOf(p[1]) == 0 && byteOf(p[2]) == 255;
        }
    EXPECT_GT(red, 50);
    EXPECT_GT(blue, 30);
    const fs::path dir = tempDir("plot");
    writeFigurePng(dir / "plot.png", img);
    EXPECT_EQ(pngSize(dir / "plot.png"), std::make_pair(640, 300));
    fs::remove_all(dir);
}

TEST(LinePlot, NiceTicks) {
    const auto t = niceTicks(0.0, 0.031, 5);
    ASSERT_FALSE(t.empty());
    EXPECT_DOUBLE_EQ(t.front(), 0.0);
    EXPECT_NEAR(t[1] - t[0], 0.01, 1e-15);
    EXPECT_LE(t.back(), 0.031);
    EXPECT_EQ(niceTicks(2.0, 2.0, 4).size() >= 1, true);
}

TEST(FigureHelpers, DownsampleAveragesBlocks) {
    ImageRgba img = patternImage(5, 4, 0);
    const ImageRgba d = downsampleImage(img, 2);
    ASSERT_EQ(d.width, 3);
    ASSERT_EQ(d.height, 2);
    EXPECT_NEAR(d.pixel(0, 0)[0], 0.5f / 255.f, 1e-7f);  // mean of x = 0, 1
    EXPECT_NEAR(d.pixel(2, 1)[0], 4.f / 255.f, 1e-7f);   // the partial last column: x = 4
    EXPECT_NEAR(d.pixel(2, 1)[1], 2.5f / 255.f, 1e-7f);  // y = 2, 3
}

TEST(FigureHelpers, TransferFunctionImageShowsItsColours) {
    TransferFunction1D tf;
    tf.colorX = {0.0, 1.0};
    tf.color = {{{1.0, 0.0, 0.0}}, {{1.0, 0.0, 0.0}}};
    tf.opacityX = {0.0, 1.0};
    tf.opacity = {0.0, 0.5};
    const ImageRgba img = renderTransferFunction(tf, 120, 90);
    ASSERT_EQ(img.width, 120);
    ASSERT_EQ(img.height, 90);
    int red = 0;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const float* p = img.pixel(x, y);
            red += byteOf(p[0]) == 255 && byteOf(p[1]) == 0 && byteOf(p[2]) == 0;
        }
    EXPECT_GT(red, 100);
}

}  // namespace
}  // namespace udvr
