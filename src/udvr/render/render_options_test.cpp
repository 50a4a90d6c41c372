#include "udvr/render/render_options.h"

#include <gtest/gtest.h>

#include <set>
#include <string>
#include <variant>

#include "udvr/classify/transfer_function_2d_widget_json.h"
#include "udvr/util/check.h"

namespace udvr {
namespace {

// The error a value gets, or "" when it is taken.
std::string errorOf(const char* name, const std::string& value) {
    RenderOptions o;
    try {
        setOption(o, *findOptionSpec(name), value, std::string("--") + name);
    } catch (const UdvrError& e) {
        return e.what();
    }
    return "";
}

TEST(RenderOptions, NamesAreUniqueAndFoundWithEitherSpelling) {
    std::set<std::string> names;
    for (auto table : {classificationOptionSpecs(), frameOptionSpecs(), forceOptionSpecs()})
        for (const OptionSpec& s : table) {
            EXPECT_TRUE(names.insert(s.name).second) << s.name;
            EXPECT_GT(std::string(s.help).size(), 10u) << s.name;
            std::string python = s.name;
            for (char& c : python)
                if (c == '-') c = '_';
            EXPECT_EQ(findOptionSpec(python), &s) << python;
        }
    EXPECT_EQ(names.size(), 21u);
    EXPECT_EQ(findOptionSpec("view_angles"), nullptr);
    EXPECT_FALSE(findOptionSpec("force")->remote);  // --force is the CLI's alone
}

// A default is written once, as its row's defaultValue: the help and RenderOptions{} read it.
TEST(RenderOptions, HelpShowsTheDefaultsOfRenderOptions) {
    EXPECT_EQ(optionHelp(*findOptionSpec("size")), "image size WxH (default 512x512)");
    EXPECT_EQ(optionHelp(*findOptionSpec("azimuth")),
              "default camera: degrees about the view-up (default 30; 0 with --view)");
    EXPECT_EQ(optionDefaultText(*findOptionSpec("elevation")), "20");
    EXPECT_EQ(optionDefaultText(*findOptionSpec("early-exit")), "0.99");
    EXPECT_EQ(optionDefaultText(*findOptionSpec("realizations")), "200");
    EXPECT_EQ(optionDefaultText(*findOptionSpec("uniform-width")), "variance");
    for (auto table : {classificationOptionSpecs(), frameOptionSpecs(), bivariateOptionSpecs(),
                       forceOptionSpecs()})
        for (const OptionSpec& s : table)
            EXPECT_EQ(optionHelp(s).find("{}"), std::string::npos) << s.name;
    const RenderOptions o;
    EXPECT_EQ(o.azimuth, kDefaultAzimuthDeg);
    EXPECT_EQ(o.viewAngle, Camera{}.viewAngleDeg);
}

// RenderOptions{} holds every row's default, and setting an option to its default text changes
// nothing: the text the help shows is the value.
TEST(RenderOptions, EveryFieldStartsAtItsRowsDefault) {
    const RenderOptions defaults;
    EXPECT_EQ(defaults.size, "512x512");
    EXPECT_EQ(defaults.uniformWidth, "variance");
    EXPECT_EQ(defaults.realizations, 200u);
    EXPECT_EQ(defaults.earlyExit, 0.99);
    EXPECT_FALSE(defaults.force);
    EXPECT_TRUE(defaults.second.empty() && defaults.position.empty());
    for (auto table : {classificationOptionSpecs(), frameOptionSpecs(), bivariateOptionSpecs(),
                       forceOptionSpecs()})
        for (const OptionSpec& s : table) {
            if (s.given && s.loOpen) continue;  // parallel-scale: its default 0 means "absent"
            RenderOptions o;
            setOption(o, s, optionDefaultText(s), s.name);
            std::visit([&](auto field) { EXPECT_EQ(o.*field, defaults.*field) << s.name; },
                       s.field);
        }
}

TEST(RenderOptions, RangesAreStatedAsTheErrorsStateThem) {
    EXPECT_EQ(optionRangeText(*findOptionSpec("zoom")), "(0, 1000]");
    EXPECT_EQ(optionRangeText(*findOptionSpec("elevation")), "[-90, 90]");
    EXPECT_EQ(optionRangeText(*findOptionSpec("realizations")), "[1, 2147483647]");
    EXPECT_EQ(optionRangeText(*findOptionSpec("size")), "");
    EXPECT_EQ(optionRangeText(*findOptionSpec("no-skip")), "");
}

TEST(RenderOptions, NumbersAreCheckedAgainstTheirRange) {
    EXPECT_EQ(errorOf("zoom", "1000"), "");
    EXPECT_EQ(errorOf("zoom", "0"), "--zoom must lie in (0, 1000], got 0");
    EXPECT_EQ(errorOf("zoom", "1000.5"), "--zoom must lie in (0, 1000], got 1000.5");
    EXPECT_EQ(errorOf("elevation", "-90"), "");
    EXPECT_EQ(errorOf("elevation", "nan"), "--elevation: 'nan' is not a finite number");
    EXPECT_EQ(errorOf("step", "0"), "");  // 0: SPEC §5's default step
    EXPECT_EQ(errorOf("step", "-1e-9"), "--step must lie in [0, 1e+12], got -1e-09");
    EXPECT_EQ(errorOf("early-exit", "1"), "");
    EXPECT_NE(errorOf("early-exit", "0"), "");
    EXPECT_EQ(errorOf("realizations", "1"), "");
    EXPECT_EQ(errorOf("realizations", "0"),
              "--realizations must be a whole number in [1, 2147483647], got '0'");
    EXPECT_NE(errorOf("realizations", "2.5"), "");
    EXPECT_NE(errorOf("seed", "-1"), "");  // not 2^64 - 1
    EXPECT_EQ(errorOf("seed", "18446744073709551615"), "");
    EXPECT_NE(errorOf("seed", "18446744073709551616"), "");
    EXPECT_EQ(errorOf("no-skip", "true"), "");
    EXPECT_EQ(errorOf("no-skip", "2"), "--no-skip must be 1 or 0 (true or false), got '2'");
    // A hostile value is cut in the message.
    EXPECT_LT(errorOf("azimuth", std::string(100000, '9') + "x").size(), 200u);
}

TEST(RenderOptions, GivenFlagsAndSettings) {
    RenderOptions o;
    setOption(o, *findOptionSpec("jitter"), "7", "jitter");
    setOption(o, *findOptionSpec("azimuth"), "45", "azimuth");
    setOption(o, *findOptionSpec("size"), "40x30", "size");
    setOption(o, *findOptionSpec("uniform_width"), "minmax", "uniform_width");
    setOption(o, *findOptionSpec("no_skip"), "1", "no_skip");
    EXPECT_TRUE(o.jitterGiven && o.azimuthGiven && !o.elevationGiven && !o.parallelGiven);
    ModelVolume m;
    m.grid.dims = {4, 4, 4};
    m.bounds = {0, 3, 0, 3, 0, 3};
    std::string note;
    const RenderSettings s = renderSettingsFromOptions(
        o, m, [] { return std::array<double, 6>{}; }, note);
    EXPECT_EQ(s.width, 40);
    EXPECT_EQ(s.height, 30);
    EXPECT_EQ(s.jitterSeed, std::optional<std::uint64_t>(7));
    EXPECT_TRUE(s.uniformMinMax);
    EXPECT_FALSE(s.skipEmpty);
    EXPECT_TRUE(note.empty());  // SPEC §5's default camera: a TF was given, no --view/--frame
    const Camera want = defaultCamera(m.bounds, 45.0, 20.0, 1.0, 30.0);
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(s.camera.position[a], want.position[a], 1e-12);
}

// --force's one help names the caps as the constants set them (the text is written by hand).
TEST(RenderOptions, ForceHelpStatesTheCaps) {
    ASSERT_EQ(forceOptionSpecs().size(), 1u);
    const std::string help = optionHelp(forceOptionSpecs()[0]);
    EXPECT_NE(help.find("--step over 1e9 samples"), std::string::npos) << help;
    EXPECT_EQ(kMaxSamplesWithoutForce, 1e9);
    EXPECT_NE(help.find("--size over 8192^2 rays"), std::string::npos) << help;
    EXPECT_EQ(kMaxPixelsWithoutForce, 8192.0 * 8192.0);
    const std::string realizations = std::to_string(kMaxRealizationsWithoutForce);
    EXPECT_NE(help.find("--realizations over " + realizations), std::string::npos) << help;
    EXPECT_NE(optionHelp(*findOptionSpec("realizations")).find("over " + realizations),
              std::string::npos);
    EXPECT_NE(help.find("over 1e8 widget evaluations"), std::string::npos) << help;
    EXPECT_EQ(kMaxTf2WidgetWorkWithoutForce, 1e8);
    EXPECT_EQ(findOptionSpec("force"), &forceOptionSpecs()[0]);
}

TEST(RenderOptions, CapsAskForForce) {
    RenderOptions o;
    o.realizations = kMaxRealizationsWithoutForce + 1;
    EXPECT_THROW(checkRenderOptions(o), UdvrError);
    o.force = true;
    EXPECT_NO_THROW(checkRenderOptions(o));
    o = {};
    o.size = "9000x8000";
    EXPECT_THROW(checkRenderOptions(o), UdvrError);
    o.uniformWidth = "wide";
    o.size = "10x10";
    EXPECT_THROW(checkRenderOptions(o), UdvrError);
}

// --second is described once: every command registers it from bivariateOptionSpecs, and one
// check says what it needs, each front end naming the two as it spells them.
TEST(RenderOptions, SecondNeedsATf2) {
    ASSERT_EQ(bivariateOptionSpecs().size(), 2u);
    for (const OptionSpec& s : bivariateOptionSpecs()) {
        EXPECT_FALSE(s.remote) << s.name;  // the server is started with it, not asked
        EXPECT_EQ(findOptionSpec(s.name), nullptr) << s.name;  // not a render keyword
    }
    RenderOptions o;
    EXPECT_NO_THROW(checkBivariateOptions(o, false));
    o.secondVar = "v";
    EXPECT_THROW(checkBivariateOptions(o, true), UdvrError);  // --second-var without --second
    EXPECT_EQ(secondFieldVar(o, "u"), "v");
    o = {};
    EXPECT_EQ(secondFieldVar(o, "u"), "u");
    o.second = "y.vti";
    EXPECT_NO_THROW(checkBivariateOptions(o, true));
    try {
        checkBivariateOptions(o, false);
        ADD_FAILURE() << "--second without --tf2 was taken";
    } catch (const UdvrError& e) {
        EXPECT_STREQ(e.what(), "--second gives the y of a 2D transfer function: it needs --tf2");
    }
    EXPECT_THROW(requireTf2ForSecond(true, false, "second", "a TransferFunction2D"), UdvrError);
}

}  // namespace
}  // namespace udvr
