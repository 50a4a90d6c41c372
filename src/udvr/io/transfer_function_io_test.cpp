#include "udvr/io/transfer_function_io.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "udvr/util/check.h"

namespace udvr {
namespace {

const char* kTangle = R"([{"Name":"bands","ColorSpace":"RGB",
  "RGBPoints":[-6.95,0.7,0.05,0.05, 0,1,0.8,0.2, 35.24,0.1,0.2,0.6],
  "Points":[-6.95,0,0.5,0, -4.5,0.9,0.5,0, -4.5,0.2,0.5,0, 35.24,0,0.5,0]}])";

TEST(TransferFunctionIo, ParsesParaViewList) {
    const TransferFunction1D tf = parseTransferFunction(kTangle, "t.json");
    ASSERT_EQ(tf.colorX.size(), 3u);
    EXPECT_DOUBLE_EQ(tf.color[1][1], 0.8);
    ASSERT_EQ(tf.opacityX.size(), 4u);
    EXPECT_DOUBLE_EQ(tf.opacityAt(-4.5), 0.2);  // step: the later point holds from x on
    EXPECT_NEAR(tf.opacityAt(-4.5 - 1e-9), 0.9, 1e-6);
    EXPECT_DOUBLE_EQ(tf.opacityAt(100.0), 0.0);  // clamped
}

TEST(TransferFunctionIo, BareObjectAndRoundTrip) {
    const TransferFunction1D tf = parseTransferFunction(
        R"({"RGBPoints":[0,1,0,0,1,0,0,1],"Points":[0,0,0.5,0,1,1,0.5,0]})", "bare");
    const TransferFunction1D back = parseTransferFunction(transferFunctionToJson(tf, "x"), "rt");
    EXPECT_EQ(back.colorX, tf.colorX);
    EXPECT_EQ(back.opacity, tf.opacity);
    EXPECT_EQ(back.color[1], tf.color[1]);
}

TEST(TransferFunctionIo, WarnsOnMidpointSharpness) {
    ::testing::internal::CaptureStderr();
    parseTransferFunction(R"({"RGBPoints":[0,1,0,0],"Points":[0,0,0.3,0,1,1,0.5,0.2]})", "w");
    const std::string err = ::testing::internal::GetCapturedStderr();
    EXPECT_NE(err.find("midpoint/sharpness"), std::string::npos);
    EXPECT_EQ(err.find("midpoint/sharpness"), err.rfind("midpoint/sharpness"));  // once
}

TEST(TransferFunctionIo, BadFilesGiveClearErrors) {
    auto fails = [](const std::string& text, const std::string& needle) {
        try {
            parseTransferFunction(text, "bad.json");
            ADD_FAILURE() << "no error for " << text;
        } catch (const UdvrError& e) {
            EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("bad.json"), std::string::npos);
        }
    };
    fails("[{\"RGBPoints\": [0,1,0", "not valid JSON");
    fails("42", "expected a ParaView transfer function");
    fails("[{\"Points\":[0,0,0.5,0]}]", "RGBPoints");
    fails("{\"RGBPoints\":[0,1,0],\"Points\":[0,0,0.5,0]}", "groups of 4");
    fails("{\"RGBPoints\":[0,1,0,0],\"Points\":[0,0,0.5]}", "groups of 4");
    fails("{\"RGBPoints\":[0,1,0,\"a\"],\"Points\":[0,0,0.5,0]}", "not a number");
    fails("{\"RGBPoints\":[1,1,0,0,0,1,0,0],\"Points\":[0,0,0.5,0]}", "sorted");
    fails("{\"RGBPoints\":[0,1,0,0],\"Points\":[0,1.5,0.5,0]}", "[0,1]");
    EXPECT_THROW(readTransferFunction("/nonexistent/tf.json"), UdvrError);
    // Found by fuzzing: a number beyond double escaped as nlohmann's out_of_range.
    fails("{\"RGBPoints\":[0,1,0,7e777777]}", "not valid JSON");
}

// Notes and warnings come after the checks: an error stays the one line on stderr (fuzzing
// found the "no Points" note printed before the "sorted" error).
TEST(TransferFunctionIo, NoNoteBeforeAnError) {
    ::testing::internal::CaptureStderr();
    EXPECT_THROW(parseTransferFunction(R"({"RGBPoints":[1,1,0,0,0,1,0,0]})", "n.json"), UdvrError);
    EXPECT_THROW(parseTransferFunction(
                     R"({"RGBPoints":[0,1,0,0],"Points":[1,0,0.3,0,0,1,0.5,0.2]})", "m.json"),
                 UdvrError);
    EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
}

TEST(TransferFunctionIo, ReadsFile) {
    const auto path = std::filesystem::temp_directory_path() / "udvr_tf_io_test.json";
    std::ofstream(path) << kTangle;
    const TransferFunction1D tf = readTransferFunction(path);
    EXPECT_EQ(tf.opacityX.size(), 4u);
    std::filesystem::remove(path);
}

}  // namespace
}  // namespace udvr
