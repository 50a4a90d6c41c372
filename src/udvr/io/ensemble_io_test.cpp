// Ensembles from member files and glob patterns: natural order, same-grid check, member count,
// voxel-major reads.
#include "udvr/io/ensemble_io.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "udvr/io/io_test_util.h"
#include "udvr/util/check.h"

namespace udvr {
namespace {

using testing::expectUdvrError;
using testing::TempDir;
using testing::writeBytes;

/// A 3×2×2 float NRRD whose every value is `value`, with the given spacing along x.
void writeMember(const std::filesystem::path& path, float value, double spacingX = 1.0) {
    std::vector<float> v(12, value);
    writeBytes(path, "NRRD0004\ntype: float\ndimension: 3\nsizes: 3 2 2\nspacings: " +
                         std::to_string(spacingX) + " 1 1\nendian: little\nencoding: raw\n\n" +
                         testing::bytesOf(v));
}

TEST(IoEnsemble, GlobSortsMembersNaturally) {
    TempDir dir;
    for (int m : {0, 1, 2, 10, 11})
        writeMember(dir / ("member_" + std::to_string(m) + ".nrrd"), float(m));
    Ensemble e = readEnsemble({(dir / "member_*.nrrd").string()}, {});
    ASSERT_EQ(e.members, 5);
    EXPECT_EQ(e.grid.dims, (std::array<int, 3>{3, 2, 2}));
    const float expected[] = {0, 1, 2, 10, 11};
    for (int m = 0; m < 5; ++m) EXPECT_EQ(e.member(m)[11], expected[m]) << m;

    // An explicit list in shell order (member_10 before member_2) comes out the same.
    std::vector<std::string> files;
    for (int m : {0, 1, 10, 11, 2})
        files.push_back((dir / ("member_" + std::to_string(m) + ".nrrd")).string());
    Ensemble f = readEnsemble(files, {});
    EXPECT_EQ(f.values, e.values);
}

TEST(IoEnsemble, RejectsBadMemberSets) {
    TempDir dir;
    writeMember(dir / "a_1.nrrd", 1.f);
    writeMember(dir / "a_2.nrrd", 2.f);
    writeMember(dir / "b_1.nrrd", 1.f, 2.0);
    expectUdvrError([&] { readEnsemble({(dir / "a_1.nrrd").string()}, {}); },
                    {"at least 2 member files", "a_1.nrrd"});
    expectUdvrError([&] { readEnsemble({(dir / "a_1*.nrrd").string()}, {}); },
                    {"at least 2 member files"});
    expectUdvrError([&] { readEnsemble({(dir / "zz_*.nrrd").string()}, {}); },
                    {"zz_*.nrrd", "matches no files"});
    expectUdvrError([&] { readEnsemble({}, {}); }, {"no ensemble input"});
    expectUdvrError(
        [&] {
            readEnsemble({(dir / "a_1.nrrd").string(), (dir / "b_1.nrrd").string()}, {});
        },
        {"different grids", "b_1.nrrd", "spacing (2,1,1)", "spacing (1,1,1)"});
    expectUdvrError(
        [&] {
            readEnsemble({(dir / "a_1.nrrd").string(), (dir / "a_9.nrrd").string()}, {});
        },
        {"a_9.nrrd", "no such file"});
    expectUdvrError(
        [&] {
            readEnsemble({(dir / "a_*.nrrd").string(), (dir / "a_2.nrrd").string()}, {});
        },
        {"a_2.nrrd", "given twice"});
    writeBytes(dir / "a_3.nrrd",
               "NRRD0004\ntype: float\ndimension: 3\nsizes: 3 2 2\n"
               "endian: little\nencoding: raw\n\nshort");
    expectUdvrError([&] { readEnsemble({(dir / "a_*.nrrd").string()}, {}); },
                    {"a_3.nrrd", "truncated"});
}

TEST(IoEnsemble, RawMembersUseTheGivenLayout) {
    TempDir dir;
    for (int m = 0; m < 3; ++m) {
        std::vector<std::uint16_t> v(12, static_cast<std::uint16_t>(m + 40));
        writeBytes(dir / ("m" + std::to_string(m) + ".raw"), testing::bytesOf(v));
    }
    EnsembleReadOptions o;
    o.raw.dims = {2, 3, 2};
    o.raw.type = "uint16";
    Ensemble e = readEnsemble({(dir / "m*.raw").string()}, o);
    ASSERT_EQ(e.members, 3);
    EXPECT_EQ(e.grid.dims, (std::array<int, 3>{2, 3, 2}));
    EXPECT_EQ(e.member(2)[5], 42.f);
}

// Voxel-major reading (the `members` layout) from member files and from NetCDF: the same
// values as member-major, transposed; checkSize sees the shape first and may refuse it.
TEST(IoEnsemble, VoxelMajorReadsTransposeAndCheckTheSizeFirst) {
    TempDir dir;
    Ensemble source;
    source.grid.dims = {3, 2, 2};
    source.members = 4;
    for (int m = 0; m < 4; ++m)
        for (int p = 0; p < 12; ++p) source.values.push_back(static_cast<float>(100 * m + p));
    std::vector<std::string> files;
    for (int m = 0; m < 4; ++m) {
        const std::vector<float> v(source.member(m), source.member(m) + 12);
        files.push_back((dir / ("m_" + std::to_string(m) + ".nrrd")).string());
        writeBytes(files.back(),
                   "NRRD0004\ntype: float\ndimension: 3\nsizes: 3 2 2\nendian: little\n"
                   "encoding: raw\n\n" +
                       testing::bytesOf(v));
    }
    writeEnsembleNetcdf(dir / "ens.nc", source);
    for (const std::vector<std::string>& inputs :
         {files, std::vector<std::string>{(dir / "ens.nc").string()}}) {
        EnsembleReadOptions o;
        o.voxelMajor = true;
        int seenMembers = 0;
        o.checkSize = [&](int members, const Grid3& grid) {
            seenMembers = members;
            EXPECT_EQ(grid.dims, source.grid.dims);
        };
        const Ensemble e = readEnsemble(inputs, o);
        EXPECT_EQ(seenMembers, 4);
        ASSERT_TRUE(e.voxelMajor);
        ASSERT_EQ(e.values.size(), 48u);
        for (int p = 0; p < 12; ++p)
            for (int m = 0; m < 4; ++m) EXPECT_EQ(e.values[p * 4 + m], source.member(m)[p]);
        o.checkSize = [](int, const Grid3&) { UDVR_FAIL("too big"); };
        expectUdvrError([&] { readEnsemble(inputs, o); }, {"too big"});
    }
}

}  // namespace
}  // namespace udvr
