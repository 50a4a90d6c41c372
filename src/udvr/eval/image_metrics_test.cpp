#include "udvr/eval/image_metrics.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "udvr/util/check.h"

namespace udvr {
namespace {

ImageRgba image(int w, int h, std::initializer_list<float> rgb) {
    ImageRgba img;
    img.width = w;
    img.height = h;
    auto it = rgb.begin();
    for (int i = 0; i < w * h; ++i) {
        for (int c = 0; c < 3; ++c) img.rgba.push_back(*it++);
        img.rgba.push_back(1.f);
    }
    return img;
}

TEST(ImageMetrics, RmseMatchesAHandComputation) {
    // Pixel means: model 0.5, 0.2, 1.0; truth 0.3, 0.2, 0.4 → d = 0.2, 0, 0.6.
    const ImageRgba model = image(3, 1, {0.5f, 0.5f, 0.5f, 0.f, 0.3f, 0.3f, 1.f, 1.f, 1.f});
    const ImageRgba truth = image(3, 1, {0.9f, 0.f, 0.f, 0.2f, 0.2f, 0.2f, 0.4f, 0.4f, 0.4f});
    const auto d = pixelDifferences(model, truth);
    ASSERT_EQ(d.size(), 3u);
    EXPECT_NEAR(d[0], 0.2, 1e-7);
    EXPECT_NEAR(d[1], 0.0, 1e-7);
    EXPECT_NEAR(d[2], 0.6, 1e-7);
    EXPECT_NEAR(imageRmse(model, truth), std::sqrt((0.04 + 0.36) / 3.0), 1e-7);
    EXPECT_EQ(imageRmse(truth, truth), 0.0);
}

TEST(ImageMetrics, SizeMismatchIsAUserError) {
    const ImageRgba a = image(2, 1, {0, 0, 0, 0, 0, 0});
    const ImageRgba b = image(1, 2, {0, 0, 0, 0, 0, 0});
    EXPECT_THROW(imageRmse(a, b), UdvrError);
    EXPECT_THROW(differenceImage(a, b), UdvrError);
}

TEST(ImageMetrics, DifferenceImageRunsBlueToYellow) {
    const ImageRgba model = image(3, 1, {0, 0, 0, 0.5f, 0.5f, 0.5f, 1, 1, 1});
    const ImageRgba truth = image(3, 1, {0, 0, 0, 0, 0, 0, 0, 0, 0});
    const ImageRgba d = differenceImage(model, truth);
    EXPECT_GT(d.pixel(0, 0)[2], d.pixel(0, 0)[0]);  // d = 0: blue
    EXPECT_GT(d.pixel(1, 0)[0], 0.9f);              // middle: near white
    EXPECT_GT(d.pixel(1, 0)[2], 0.9f);
    EXPECT_GT(d.pixel(2, 0)[0], 0.9f);  // largest d: yellow
    EXPECT_LT(d.pixel(2, 0)[2], 0.1f);
    EXPECT_EQ(d.pixel(2, 0)[3], 1.f);
    // With a fixed scale twice the largest difference the top pixel is only mid-scale.
    const ImageRgba half = differenceImage(model, truth, 2.0);
    EXPECT_NEAR(half.pixel(2, 0)[0], d.pixel(1, 0)[0], 1e-6);
}

#ifdef UDVR_BINARY
TEST(ImageMetrics, CompareCommandPrintsRmseAndRejectsSizeMismatch) {
    namespace fs = std::filesystem;
    const fs::path dir =
        fs::temp_directory_path() / ("udvr_compare_test_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    writePng(dir / "a.png", image(2, 1, {1, 1, 1, 0, 0, 0}));
    writePng(dir / "b.png", image(2, 1, {0, 0, 0, 0, 0, 0}));
    writePng(dir / "c.png", image(1, 2, {0, 0, 0, 0, 0, 0}));
    const std::string bin = UDVR_BINARY;
    const std::string out = (dir / "out.txt").string();
    ASSERT_EQ(
        std::system((bin + " compare " + (dir / "a.png").string() + " " + (dir / "b.png").string() +
                     " --diff " + (dir / "d.png").string() + " > " + out)
                        .c_str()),
        0);
    std::FILE* f = std::fopen(out.c_str(), "r");
    ASSERT_NE(f, nullptr);
    double rmse = -1;
    ASSERT_EQ(std::fscanf(f, "%lf", &rmse), 1);
    std::fclose(f);
    EXPECT_NEAR(rmse, std::sqrt(0.5), 1e-6);  // d = 1, 0
    EXPECT_TRUE(fs::exists(dir / "d.png"));
    EXPECT_NE(std::system((bin + " compare " + (dir / "a.png").string() + " " +
                           (dir / "c.png").string() + " 2> /dev/null")
                              .c_str()),
              0);
    fs::remove_all(dir);
}
#endif

// A w×h image whose alpha is 1 where mask has '#', 0 elsewhere (rows from the top).
ImageRgba maskImage(const std::vector<std::string>& mask) {
    ImageRgba img;
    img.height = static_cast<int>(mask.size());
    img.width = static_cast<int>(mask[0].size());
    img.rgba.assign(static_cast<std::size_t>(img.width) * img.height * 4, 0.f);
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x)
            img.rgba[(static_cast<std::size_t>(y) * img.width + x) * 4 + 3] =
                mask[y][x] == '#' ? 1.f : 0.f;
    return img;
}

TEST(ImageMetrics, OpaqueComponentsCountPiecesAndHoles) {
    // A ring with one hole, a diagonal pair (one piece, 8-neighbourhood) and a lone pixel.
    const MaskComponents a = opaqueComponents(
        maskImage({"........", ".####...", ".#..#.#.", ".####..#", "........", "......#."}), 0.1f);
    EXPECT_EQ(a.count, 3);
    EXPECT_EQ(a.holes, 1);
    EXPECT_EQ(a.pixels, 13u);
    EXPECT_EQ(a.largest, 10u);
    // A gap diagonal in the ring's wall connects its hole to the outside (4-neighbourhood for
    // the background), and a C touching the border has no hole.
    const MaskComponents b =
        opaqueComponents(maskImage({"#####", "#...#", "#...#", "#.###"}), 0.1f);
    EXPECT_EQ(b.count, 1);
    EXPECT_EQ(b.holes, 0);
    const MaskComponents none = opaqueComponents(maskImage({"...", "..."}), 0.1f);
    EXPECT_EQ(none.count, 0);
    EXPECT_EQ(none.holes, 0);
    EXPECT_EQ(opaqueComponents(maskImage({"##"}), 1.f).count, 0);  // alpha must exceed
}

}  // namespace
}  // namespace udvr
