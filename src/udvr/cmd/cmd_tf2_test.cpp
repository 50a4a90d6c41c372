// `udvr tf2` end to end: the built binary on small files.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "udvr/io/field_io.h"
#include "udvr/io/io_test_util.h"
#include "udvr/io/transfer_function_2d_io.h"

namespace udvr {
namespace {

#ifdef UDVR_BINARY
namespace fs = std::filesystem;
using testing::readBytes;
using testing::TempDir;
using testing::writeBytes;

/// Run `udvr ARGS` with stdout and stderr to files in `dir`; the exit status.
int runUdvr(const TempDir& dir, const std::string& args) {
    const std::string cmd = std::string(UDVR_BINARY) + " " + args + " > " +
                            (dir / "out.txt").string() + " 2> " + (dir / "err.txt").string();
    const int status = std::system(cmd.c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

int lineCount(const std::string& text) {
    int n = 0;
    for (char c : text) n += c == '\n';
    return n;
}

const char* kWidgets = R"({"domain": [-1, 1, 0, 4], "resolution": [32, 16], "widgets": [
  {"type": "ellipse", "center": [0, 2], "sigma": [0.3, 1], "rgba": [1, 0.5, 0, 0.8]}]})";

TEST(Tf2Cli, WritesRastersAndPlots) {
    TempDir dir;
    writeBytes(dir / "w.json", kWidgets);
    // A small field: f = x on an 8³ grid (gradient magnitude 1 everywhere inside).
    ScalarField f;
    f.grid.dims = {8, 8, 8};
    f.grid.spacing = {0.25, 0.25, 0.25};
    f.grid.origin = {-1.0, 0.0, 0.0};
    for (int k = 0; k < 8; ++k)
        for (int j = 0; j < 8; ++j)
            for (int i = 0; i < 8; ++i) f.values.push_back(static_cast<float>(-1.0 + 0.25 * i));
    writeFieldVti(dir / "f.vti", f);

    const std::string w = (dir / "w.json").string();
    ASSERT_EQ(runUdvr(dir, "tf2 " + w + " -o " + (dir / "r.vti").string() + " --volume " +
                               (dir / "f.vti").string() + " --png " + (dir / "p.png").string() +
                               " --bins 16 --log --size 320x240"),
              0)
        << readBytes(dir / "err.txt");
    EXPECT_TRUE(fs::exists(dir / "p.png"));
    const std::string out = readBytes(dir / "out.txt");
    EXPECT_NE(out.find("tf2: 32x16 points"), std::string::npos) << out;
    EXPECT_NE(out.find("histogram: 512 grid points"), std::string::npos) << out;
    const TransferFunction2D r = readTransferFunction2D(dir / "r.vti");
    EXPECT_EQ(r.width, 32);
    EXPECT_EQ(r.y1, 4.0);

    // Raster to raster, and the TF alone as a picture.
    ASSERT_EQ(runUdvr(dir, "tf2 " + (dir / "r.vti").string() + " -o " + (dir / "r.npy").string() +
                               " --png " + (dir / "q.png").string()),
              0)
        << readBytes(dir / "err.txt");
    EXPECT_TRUE(fs::exists(dir / "q.png"));
    ASSERT_EQ(runUdvr(dir, "tf2 " + (dir / "r.npy").string() + " --tf2-domain -1,1,0,4"), 0);
    EXPECT_EQ(lineCount(readBytes(dir / "out.txt")), 1);
}

TEST(Tf2Cli, BadInputsGiveOneLineAndNonZeroExit) {
    TempDir dir;
    writeBytes(dir / "w.json", kWidgets);
    writeBytes(dir / "bad.json", R"({"domain": [0, 1, 0, 1], "widgets": [{"type": "blob"}]})");
    const std::string w = (dir / "w.json").string();
    const auto failsWith = [&](const std::string& args, const std::string& needle) {
        EXPECT_NE(runUdvr(dir, args), 0) << args;
        const std::string err = readBytes(dir / "err.txt");
        EXPECT_EQ(lineCount(err), 1) << err;
        EXPECT_NE(err.find(needle), std::string::npos) << err;
    };
    failsWith("tf2 " + (dir / "bad.json").string(), "widget 0");
    failsWith("tf2 " + (dir / "missing.npy").string() + " --tf2-domain 0,1,0,1", "no such file");
    failsWith("tf2 " + w + " --tf2-domain 0,1,0", "x0,x1,y0,y1");
    failsWith("tf2 " + w + " -o " + (dir / "r.png").string(), ".vti or .npy");
    failsWith("tf2 " + w + " --png " + (dir / "nodir" / "p.png").string(), "does not exist");
    failsWith("tf2 " + w + " --volume " + (dir / "nothing.vti").string(), "nothing.vti");
    EXPECT_FALSE(fs::exists(dir / "r.png"));
}
#endif

}  // namespace
}  // namespace udvr
