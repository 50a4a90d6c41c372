// Partitioned models (.pvti, issue 15 point 3): written in z-pieces, read back as one model,
// read by VTK's own parallel reader (what ParaView uses), and bad headers and pieces.
#include <gtest/gtest.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkXMLPImageDataReader.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <regex>

#include "udvr/io/field_io.h"
#include "udvr/io/file_info.h"
#include "udvr/io/io_test_util.h"
#include "udvr/io/model_io.h"

namespace udvr {
namespace {

using testing::expectUdvrError;
using testing::readBytes;
using testing::TempDir;
using testing::writeBytes;

/// A model of random values on a 5×4×`nz` grid with every array, arranged as a model holds them
/// (checkModelArrays): stddev and σ ≥ 0, min ≤ max, boundaries increasing, weights in [0, 1].
ModelVolume randomModel(int nz, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-3.f, 7.f);
    ModelVolume m;
    m.grid.dims = {5, 4, nz};
    m.grid.origin = {-1.25, 0.5, 3.0};
    m.grid.spacing = {0.5, 0.75, 1.0 / 3.0};
    const std::size_t n = m.voxelCount();
    auto fill = [&](std::vector<float>& v, std::size_t c) {
        v.resize(n * c);
        for (float& x : v) x = u(rng);
    };
    fill(m.mean, 1);
    fill(m.stddev, 1);
    fill(m.min, 1);
    fill(m.max, 1);
    m.quantileCount = 4;
    fill(m.quantiles, 5);
    fill(m.iqr, 2);
    m.gmmComponents = 2;
    fill(m.gmm, 6);
    for (std::size_t v = 0; v < n; ++v) {
        m.stddev[v] = std::abs(m.stddev[v]);
        if (m.min[v] > m.max[v]) std::swap(m.min[v], m.max[v]);
        std::sort(m.quantiles.begin() + 5 * v, m.quantiles.begin() + 5 * (v + 1));
        std::sort(m.iqr.begin() + 2 * v, m.iqr.begin() + 2 * (v + 1));
        for (int c : {0, 1, 4, 5}) {  // weights in [0, 1], σ ≥ 0
            float& g = m.gmm[6 * v + c];
            g = c < 2 ? (g + 3.f) / 10.f : std::abs(g);
        }
    }
    m.samplesPerVoxel = 12;
    m.bounds = m.grid.bounds();
    m.fullResMinSpacing = 1.0 / 3.0;
    m.source = "pieces test";
    return m;
}

void expectSameModel(const ModelVolume& r, const ModelVolume& m) {
    EXPECT_EQ(r.grid.dims, m.grid.dims);
    for (int a = 0; a < 3; ++a) {
        EXPECT_DOUBLE_EQ(r.grid.origin[a], m.grid.origin[a]);
        EXPECT_DOUBLE_EQ(r.grid.spacing[a], m.grid.spacing[a]);
    }
    EXPECT_EQ(r.mean, m.mean);
    EXPECT_EQ(r.stddev, m.stddev);
    EXPECT_EQ(r.min, m.min);
    EXPECT_EQ(r.max, m.max);
    EXPECT_EQ(r.quantiles, m.quantiles);
    EXPECT_EQ(r.quantileCount, m.quantileCount);
    EXPECT_EQ(r.iqr, m.iqr);
    EXPECT_EQ(r.gmm, m.gmm);
    EXPECT_EQ(r.gmmComponents, m.gmmComponents);
    EXPECT_EQ(r.samplesPerVoxel, m.samplesPerVoxel);
    EXPECT_EQ(r.source, m.source);
}

TEST(IoPvti, PieceBoundariesShareOnePlaneAndCoverTheGrid) {
    EXPECT_EQ(pvtiPieceBoundaries(9, 1), (std::vector<int>{0, 8}));
    EXPECT_EQ(pvtiPieceBoundaries(9, 3), (std::vector<int>{0, 2, 5, 8}));
    EXPECT_EQ(pvtiPieceBoundaries(9, 8), (std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7, 8}));
    EXPECT_EQ(pvtiPieceBoundaries(9, 50), pvtiPieceBoundaries(9, 8));  // one cell layer each
    EXPECT_EQ(pvtiPieceBoundaries(1, 4), (std::vector<int>{0, 0}));    // one plane: one piece
}

TEST(IoPvti, RoundTripForAnyNumberOfPieces) {
    for (int nz : {1, 2, 9}) {
        for (int pieces : {1, 2, 3, 7, 40}) {
            SCOPED_TRACE("nz " + std::to_string(nz) + ", pieces " + std::to_string(pieces));
            TempDir dir;
            const ModelVolume m = randomModel(nz, static_cast<unsigned>(nz * 100 + pieces));
            writeModelPvti(dir / "m.pvti", m, pieces);
            const int expected = std::min(pieces, std::max(nz - 1, 1));
            EXPECT_EQ(testing::fileCount(dir / "m"), static_cast<std::size_t>(expected));
            expectSameModel(readModelVti(dir / "m.pvti"), m);
            expectSameModel(readModelOrField(dir / "m.pvti"), m);
            const std::vector<ArrayInfo> arrays = listArrays(dir / "m.pvti");
            ASSERT_EQ(arrays.size(), 7u);
            EXPECT_EQ(arrays[4].name, "quantiles");
            EXPECT_EQ(arrays[4].components, 5);
        }
    }
}

// VTK's parallel reader, which ParaView uses, assembles the same whole image.
TEST(IoPvti, VtkParallelReaderReadsIt) {
    TempDir dir;
    const ModelVolume m = randomModel(9, 7);
    writeModelPvti(dir / "m.pvti", m, 3);
    vtkNew<vtkXMLPImageDataReader> reader;
    const std::string name = (dir / "m.pvti").string();
    reader->SetFileName(name.c_str());
    reader->Update();
    vtkImageData* image = reader->GetOutput();
    ASSERT_NE(image, nullptr);
    int extent[6];
    image->GetExtent(extent);
    EXPECT_EQ(std::vector<int>(extent, extent + 6), (std::vector<int>{0, 4, 0, 3, 0, 8}));
    double origin[3];
    image->GetOrigin(origin);
    EXPECT_DOUBLE_EQ(origin[2], 3.0);
    auto* mean = vtkFloatArray::SafeDownCast(image->GetPointData()->GetArray("mean"));
    auto* quantiles = vtkFloatArray::SafeDownCast(image->GetPointData()->GetArray("quantiles"));
    ASSERT_NE(mean, nullptr);
    ASSERT_NE(quantiles, nullptr);
    ASSERT_EQ(mean->GetNumberOfTuples(), 180);
    for (vtkIdType i = 0; i < 180; ++i) {
        ASSERT_EQ(mean->GetValue(i), m.mean[static_cast<std::size_t>(i)]) << i;
        for (int c = 0; c < 5; ++c)
            ASSERT_EQ(quantiles->GetTypedComponent(i, c),
                      m.quantiles[static_cast<std::size_t>(i) * 5 + static_cast<std::size_t>(c)]);
    }
}

TEST(IoPvti, FewerPiecesRemoveTheStaleOnes) {
    TempDir dir;
    const ModelVolume m = randomModel(9, 3);
    writeModelPvti(dir / "m.pvti", m, 5);
    EXPECT_EQ(testing::fileCount(dir / "m"), 5u);
    writeModelPvti(dir / "m.pvti", m, 2);
    EXPECT_EQ(testing::fileCount(dir / "m"), 2u);
    expectSameModel(readModelVti(dir / "m.pvti"), m);
}

TEST(IoPvti, BadHeadersAndPiecesAreOneLineErrors) {
    TempDir dir;
    const ModelVolume m = randomModel(9, 5);
    writeModelPvti(dir / "m.pvti", m, 3);
    const std::string header = readBytes(dir / "m.pvti");
    auto edited = [&](const std::string& from, const std::string& to) {
        std::string h = header;
        const std::size_t at = h.find(from);
        EXPECT_NE(at, std::string::npos) << from;
        return h.replace(at, from.size(), to);
    };
    auto rejects = [&](const std::string& text, std::initializer_list<std::string> parts) {
        writeBytes(dir / "bad.pvti", text);
        // The pieces are found relative to the header: bad.pvti names m/m_<i>.vti as m.pvti does.
        expectUdvrError([&] { readModelVti(dir / "bad.pvti"); }, parts);
        expectUdvrError([&] { readModelOrField(dir / "bad.pvti"); }, {"bad.pvti"});
    };
    rejects("not xml <", {"bad.pvti", "cannot parse it as XML"});
    rejects(edited("PImageData\"", "ImageData\""), {"bad.pvti", "PImageData"});
    rejects(edited("WholeExtent=\"0 4", "WholeExtent=\"0 x"), {"WholeExtent", "not 6 integers"});
    rejects(edited("Spacing=\"0.5", "Spacing=\"-0.5"), {"Spacing along axis 0"});
    rejects(edited("Source=\"m/m_1.vti\"", "Source=\"m/m_9.vti\""), {"m_9.vti", "no such file"});
    rejects(edited("Source=\"m/m_1.vti\"", "Source=\"bad.pvti\""), {"expected a .vti file"});
    rejects(edited("Extent=\"0 4 0 3 2 5\"", "Extent=\"0 4 0 3 3 5\""),
            {"piece 1", "has more than 60 points"});
    rejects(edited("Extent=\"0 4 0 3 2 5\"", "Extent=\"0 4 0 3 1 4\""),
            {"piece 1", "not the Extent the .pvti gives it"});
    rejects(edited("Extent=\"0 4 0 3 0 2\"", "Extent=\"0 4 0 3 0 12\""),
            {"outside the WholeExtent"});
    // Piece 1 left out: plane 3 and 4 are in no piece.
    const std::size_t from = header.find("    <Piece Extent=\"0 4 0 3 2 5\"");
    const std::size_t to = header.find('\n', from) + 1;
    std::string gap = header;
    gap.erase(from, to - from);
    rejects(gap, {"bad.pvti", "do not cover point (0, 0, 3)"});
    // A piece from another model: other arrays.
    ModelVolume meanOnly = randomModel(9, 5);
    meanOnly.quantiles.clear();
    meanOnly.quantileCount = 0;
    writeModelPvti(dir / "other.pvti", meanOnly, 3);
    std::filesystem::copy_file(dir / "other" / "other_2.vti", dir / "m" / "m_2.vti",
                               std::filesystem::copy_options::overwrite_existing);
    rejects(header, {"piece 2", "no point array 'quantiles'"});
}

}  // namespace
}  // namespace udvr
