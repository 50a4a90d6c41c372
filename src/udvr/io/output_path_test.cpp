// requireOutputsNotInputs (issue 34, item 10) and the XML nesting pre-scan (item 11).
#include "udvr/io/output_path.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "udvr/io/vti_check.h"
#include "udvr/util/check.h"

namespace udvr {
namespace {
namespace fs = std::filesystem;

struct TempDir {
    fs::path path;
    TempDir() {
        path = fs::temp_directory_path() / ("udvr_output_path_test_" + std::to_string(::getpid()));
        fs::remove_all(path);
        fs::create_directories(path);
    }
    ~TempDir() { fs::remove_all(path); }
};

void touch(const fs::path& p, const std::string& text = "x") { std::ofstream(p) << text; }

std::string errorOf(const std::string& out, const std::vector<std::string>& inputs) {
    try {
        requireOutputsNotInputs({{"-o", out}}, inputs);
    } catch (const UdvrError& e) {
        return e.what();
    }
    return "";
}

TEST(OutputPath, RefusesAnOutputThatResolvesToAnInput) {
    TempDir d;
    const fs::path in = d.path / "t.vti";
    touch(in);
    fs::create_symlink(in, d.path / "link.vti");
    fs::create_hard_link(in, d.path / "hard.vti");
    fs::create_directories(d.path / "sub");
    for (const fs::path& out :
         {in, d.path / "link.vti", d.path / "hard.vti", d.path / "sub" / ".." / "t.vti"})
        EXPECT_NE(errorOf(out.string(), {in.string()}).find("is also an input"), std::string::npos)
            << out;
    EXPECT_EQ(errorOf((d.path / "other.vti").string(), {in.string()}), "");
    EXPECT_EQ(errorOf("", {in.string()}), "");
    EXPECT_EQ(errorOf((d.path / "new.vti").string(), {(d.path / "missing.vti").string()}), "");
}

TEST(OutputPath, GlobsStandForTheirMatches) {
    TempDir d;
    for (int i = 1; i <= 3; ++i) touch(d.path / ("mem_" + std::to_string(i) + ".vti"));
    const std::string glob = (d.path / "mem_*.vti").string();
    const std::string e = errorOf((d.path / "mem_2.vti").string(), {glob});
    EXPECT_NE(e.find("matched by '" + glob + "'"), std::string::npos) << e;
    EXPECT_EQ(errorOf((d.path / "model.vti").string(), {glob}), "");
    EXPECT_EQ(errorOf((d.path / "model.vti").string(), {(d.path / "none_*.vti").string()}), "");
}

TEST(OutputPath, PvtiPiecesCountAsItsFiles) {
    TempDir d;
    touch(d.path / "m.pvti");
    fs::create_directories(d.path / "m");
    touch(d.path / "m" / "m_0.vti");
    const std::string pvti = (d.path / "m.pvti").string(), piece = (d.path / "m/m_0.vti").string();
    EXPECT_NE(errorOf(piece, {pvti}).find("piece"), std::string::npos);
    EXPECT_NE(errorOf((d.path / "m/m_7.vti").string(), {pvti}).find("piece"), std::string::npos);
    EXPECT_NE(errorOf(pvti, {piece}).find("piece"), std::string::npos);
    EXPECT_EQ(errorOf((d.path / "m/view.png").string(), {pvti}), "");
}

std::string nesting(const std::string& text) {
    TempDir d;
    const fs::path p = d.path / "x.vti";
    touch(p, text);
    return detail::xmlNestingProblem(p, 4);
}

TEST(XmlNesting, CountsElementsOnly) {
    EXPECT_EQ(nesting("<?xml version=\"1.0\"?><a><b><c><d/></c></b></a>"), "");
    EXPECT_NE(nesting("<a><b><c><d><e></e></d></c></b></a>"), "");
    EXPECT_EQ(nesting("<a><b></b><b></b><b></b><b></b><b></b></a>"), "");
    // Comments, CDATA, processing instructions, DOCTYPE and quoted '>' or '<' are not elements.
    EXPECT_EQ(nesting("<!DOCTYPE a [<!ELEMENT a ANY>]><a x=\"<b>\" y='>'><!-- <b><c><d><e> -->"
                      "<![CDATA[<b><c><d><e>]]><?pi <b><c>?><b/></a>"),
              "");
    // Raw appended data after <AppendedData> is not scanned.
    EXPECT_EQ(nesting("<a><AppendedData encoding=\"raw\">_<b><c><d><e><f></AppendedData></a>"), "");
    std::string deep;
    for (int i = 0; i < 3000; ++i) deep += "<a>";
    EXPECT_EQ(nesting(deep).find("XML elements nested deeper than 4"), 0u);
    EXPECT_NE(nesting("<a><b><c><d><e>").find("at byte 12"), std::string::npos);
}

}  // namespace
}  // namespace udvr
