// VTK XML ImageData: fields written by VTK's own writer, our writer read back by VTK, model
// volumes round trip, and bad input.
#include <gtest/gtest.h>
#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkShortArray.h>
#include <vtkStringArray.h>
#include <vtkUnsignedCharArray.h>
#include <vtkXMLImageDataReader.h>
#include <vtkXMLImageDataWriter.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <regex>

#include "udvr/io/field_io.h"
#include "udvr/io/file_info.h"
#include "udvr/io/io_test_util.h"
#include "udvr/io/model_io.h"

namespace udvr {
namespace {

using testing::expectUdvrError;
using testing::fileCount;
using testing::readBytes;
using testing::TempDir;
using testing::writeBytes;

enum class Mode { kAppendedRaw, kAppendedZlib, kAscii };

/// A 5×4×3 image on extent [2,6]×[0,3]×[1,3]: "value" (float64, i+10j+100k) and "other" (float),
/// with `scalars` as the active scalars; written by vtkXMLImageDataWriter.
void writeWithVtk(const std::filesystem::path& path, Mode mode, const char* scalars,
                  double poison = 0.0) {
    vtkNew<vtkImageData> image;
    image->SetExtent(2, 6, 0, 3, 1, 3);
    image->SetOrigin(10.0, 20.0, 30.0);
    image->SetSpacing(0.5, 0.25, 2.0);
    vtkNew<vtkDoubleArray> value;
    value->SetName("value");
    vtkNew<vtkFloatArray> other;
    other->SetName("other");
    for (int k = 0; k < 3; ++k)
        for (int j = 0; j < 4; ++j)
            for (int i = 0; i < 5; ++i) {
                value->InsertNextValue(i + 10 * j + 100 * k);
                other->InsertNextValue(-1.0f);
            }
    if (poison != 0.0) value->SetValue(7, poison);
    image->GetPointData()->AddArray(value);
    image->GetPointData()->AddArray(other);
    image->GetPointData()->SetActiveScalars(scalars);
    vtkNew<vtkXMLImageDataWriter> writer;
    writer->SetFileName(path.c_str());
    writer->SetInputData(image);
    if (mode == Mode::kAscii) {
        writer->SetDataModeToAscii();
    } else {
        writer->SetDataModeToAppended();
        writer->EncodeAppendedDataOff();
        if (mode == Mode::kAppendedRaw) writer->SetCompressorTypeToNone();
    }
    ASSERT_EQ(writer->Write(), 1);
}

TEST(IoVti, ReadsFilesWrittenByVtk) {
    TempDir dir;
    for (Mode mode : {Mode::kAppendedRaw, Mode::kAppendedZlib, Mode::kAscii}) {
        writeWithVtk(dir / "f.vti", mode, "value");
        ScalarField f = readField(dir / "f.vti");
        EXPECT_EQ(f.name, "value");
        ASSERT_EQ(f.grid.dims, (std::array<int, 3>{5, 4, 3}));
        // The first point of the extent is our index 0: origin + extent start · spacing.
        EXPECT_EQ(f.grid.origin, (std::array<double, 3>{11.0, 20.0, 32.0}));
        EXPECT_EQ(f.grid.spacing, (std::array<double, 3>{0.5, 0.25, 2.0}));
        EXPECT_EQ(f.values[f.grid.index(4, 3, 2)], 234.f);
        EXPECT_EQ(f.values[f.grid.index(1, 2, 0)], 21.f);
    }
    // Active scalars win; --var picks another array.
    writeWithVtk(dir / "g.vti", Mode::kAppendedRaw, "other");
    EXPECT_EQ(readField(dir / "g.vti").name, "other");
    FieldReadOptions o;
    o.var = "value";
    EXPECT_EQ(readField(dir / "g.vti", o).values[1], 1.f);
}

// The array's type travels with the field: integers have quantisation step 1, floats none.
TEST(IoVti, ValueTypeAndStepOfTheArray) {
    TempDir dir;
    writeWithVtk(dir / "f.vti", Mode::kAppendedRaw, "value");
    const ScalarField f = readField(dir / "f.vti");
    EXPECT_EQ(f.valueType, "float64");
    EXPECT_EQ(f.valueStep, 0.0);
    vtkNew<vtkImageData> image;
    image->SetDimensions(2, 2, 2);
    vtkNew<vtkUnsignedCharArray> bytes;
    bytes->SetName("u8");
    vtkNew<vtkShortArray> shorts;
    shorts->SetName("s16");
    for (int i = 0; i < 8; ++i) {
        bytes->InsertNextValue(static_cast<unsigned char>(200 + i));
        shorts->InsertNextValue(static_cast<short>(-i));
    }
    image->GetPointData()->AddArray(bytes);
    image->GetPointData()->AddArray(shorts);
    vtkNew<vtkXMLImageDataWriter> writer;
    writer->SetFileName((dir / "i.vti").c_str());
    writer->SetInputData(image);
    ASSERT_EQ(writer->Write(), 1);
    FieldReadOptions o;
    o.var = "u8";
    const ScalarField u = readField(dir / "i.vti", o);
    EXPECT_EQ(u.valueType, "uint8");
    EXPECT_EQ(u.valueStep, 1.0);
    EXPECT_EQ(u.values[7], 207.f);
    o.var = "s16";
    EXPECT_EQ(readField(dir / "i.vti", o).valueType, "int16");
}

TEST(IoVti, WriterRoundTripAndVtkCanReadIt) {
    TempDir dir;
    ScalarField f;
    f.grid.dims = {3, 2, 4};
    f.grid.origin = {-1.0, 0.5, 2.0};
    f.grid.spacing = {0.1, 0.2, 0.3};
    f.name = "density";
    for (std::size_t i = 0; i < f.grid.pointCount(); ++i) f.values.push_back(0.5f * float(i));
    writeField(dir / "out.vti", f);
    EXPECT_EQ(testing::fileCount(dir.path()), 1u);  // no temporary left

    ScalarField g = readField(dir / "out.vti");
    EXPECT_EQ(g.grid.dims, f.grid.dims);
    EXPECT_EQ(g.grid.origin, f.grid.origin);
    EXPECT_EQ(g.grid.spacing, f.grid.spacing);
    EXPECT_EQ(g.values, f.values);
    EXPECT_EQ(g.name, "density");

    vtkNew<vtkXMLImageDataReader> reader;
    reader->SetFileName((dir / "out.vti").c_str());
    reader->Update();
    vtkImageData* image = reader->GetOutput();
    ASSERT_NE(image->GetPointData()->GetScalars(), nullptr);
    EXPECT_STREQ(image->GetPointData()->GetScalars()->GetName(), "density");
    EXPECT_EQ(image->GetNumberOfPoints(), 24);
}

TEST(IoVti, RejectsBadInput) {
    TempDir dir;
    writeWithVtk(dir / "f.vti", Mode::kAppendedRaw, "value");
    std::string bytes = readBytes(dir / "f.vti");

    writeBytes(dir / "short.vti", bytes.substr(0, bytes.size() - 200));
    expectUdvrError([&] { readField(dir / "short.vti"); },
                    {"short.vti", "truncated", "expected at least"});

    // Our writer's zlib-compressed output, cut inside the last compressed block.
    ScalarField big;
    big.grid.dims = {16, 16, 16};
    for (std::size_t i = 0; i < big.grid.pointCount(); ++i) {
        big.values.push_back(float((i * 2654435761u) % 1000u));
    }
    writeFieldVti(dir / "z.vti", big);
    std::string zbytes = readBytes(dir / "z.vti");
    writeBytes(dir / "zshort.vti", zbytes.substr(0, zbytes.size() - 100));
    expectUdvrError([&] { readField(dir / "zshort.vti"); }, {"zshort.vti", "truncated"});

    writeBytes(dir / "garbage.vti", "<html>not vtk</html>");
    expectUdvrError([&] { readField(dir / "garbage.vti"); }, {"garbage.vti", "ImageData"});

    // WholeExtent and Piece extent grown by one plane: the arrays are too short for the grid.
    std::string grown = bytes;
    for (std::size_t p = 0; (p = grown.find("Extent=\"2 6 0 3 1 3\"", p)) != std::string::npos;) {
        grown.replace(p, 20, "Extent=\"2 6 0 3 1 4\"");
    }
    writeBytes(dir / "dims.vti", grown);
    expectUdvrError([&] { readField(dir / "dims.vti"); }, {"dims.vti"});

    FieldReadOptions o;
    o.var = "nope";
    expectUdvrError([&] { readField(dir / "f.vti", o); },
                    {"f.vti", "no point array 'nope'", "value, other"});

    writeWithVtk(dir / "nan.vti", Mode::kAppendedRaw, "value",
                 std::numeric_limits<double>::quiet_NaN());
    expectUdvrError([&] { readField(dir / "nan.vti"); }, {"nan.vti", "1 NaN", "(2,1,0)"});
    writeWithVtk(dir / "inf.vti", Mode::kAppendedRaw, "value", 1e300);  // beyond float32
    expectUdvrError([&] { readField(dir / "inf.vti"); }, {"inf.vti", "1 Inf"});
}

ModelVolume sampleModel() {
    ModelVolume m;
    m.grid.dims = {3, 2, 2};
    m.grid.origin = {0.5, 1.0, 1.5};
    m.grid.spacing = {2.0, 2.0, 2.0};
    std::size_t n = m.voxelCount();
    for (std::size_t v = 0; v < n; ++v) {
        float x = static_cast<float>(v);
        m.mean.push_back(x);
        m.stddev.push_back(0.1f * x);
        m.min.push_back(x - 1);
        m.max.push_back(x + 1);
        for (int j = 0; j <= 4; ++j) m.quantiles.push_back(x - 1 + 0.5f * float(j));
        m.iqr.push_back(x - 0.5f);
        m.iqr.push_back(x + 0.5f);
        m.gmm.insert(m.gmm.end(), {0.25f, 0.75f, x - 0.5f, x + 0.5f, 0.5f, 0.25f + 0.01f * x});
    }
    m.quantileCount = 4;
    m.gmmComponents = 2;
    m.density = "kde";
    m.bandwidth = 0.37;
    m.bandwidthRule = "silverman";
    m.tailEps = 0.05;
    m.samplesPerVoxel = 8;
    m.downsample = 2;
    m.bounds = {0.0, 5.0, 0.5, 3.5, 1.0, 4.0};
    m.fullResMinSpacing = 1.0;
    m.source = "tooth.nhdr --downsample 2";
    return m;
}

TEST(IoModel, RoundTripKeepsArraysAndFieldData) {
    TempDir dir;
    ModelVolume m = sampleModel();
    writeModelVti(dir / "model.vti", m);
    ModelVolume r = readModelVti(dir / "model.vti");
    EXPECT_EQ(r.grid.dims, m.grid.dims);
    EXPECT_EQ(r.grid.origin, m.grid.origin);
    EXPECT_EQ(r.grid.spacing, m.grid.spacing);
    EXPECT_EQ(r.mean, m.mean);
    EXPECT_EQ(r.stddev, m.stddev);
    EXPECT_EQ(r.min, m.min);
    EXPECT_EQ(r.max, m.max);
    EXPECT_EQ(r.quantiles, m.quantiles);
    EXPECT_EQ(r.quantileCount, 4);
    EXPECT_EQ(r.iqr, m.iqr);
    EXPECT_EQ(r.gmm, m.gmm);
    EXPECT_EQ(r.gmmComponents, 2);
    EXPECT_EQ(r.density, "kde");
    EXPECT_EQ(r.bandwidth, 0.37);
    EXPECT_EQ(r.bandwidthRule, "silverman");
    EXPECT_EQ(r.tailEps, 0.05);
    EXPECT_EQ(r.samplesPerVoxel, 8);
    EXPECT_EQ(r.downsample, 2);
    EXPECT_EQ(r.bounds, m.bounds);
    EXPECT_EQ(r.fullResMinSpacing, 1.0);
    EXPECT_EQ(r.source, m.source);

    // A plain VTK reader (as ParaView uses) sees the named arrays and field data.
    vtkNew<vtkXMLImageDataReader> reader;
    reader->SetFileName((dir / "model.vti").c_str());
    reader->Update();
    vtkImageData* image = reader->GetOutput();
    ASSERT_NE(image->GetPointData()->GetArray("quantiles"), nullptr);
    EXPECT_EQ(image->GetPointData()->GetArray("quantiles")->GetNumberOfComponents(), 5);
    EXPECT_EQ(image->GetPointData()->GetArray("gmm")->GetNumberOfComponents(), 6);
    auto* density =
        vtkStringArray::SafeDownCast(image->GetFieldData()->GetAbstractArray("density"));
    ASSERT_NE(density, nullptr);
    EXPECT_EQ(density->GetValue(0), "kde");
}

TEST(IoModel, OnlyPresentArraysAndEmptyStrings) {
    TempDir dir;
    ModelVolume m = sampleModel();
    m.quantiles.clear();
    m.quantileCount = 0;
    m.gmm.clear();
    m.gmmComponents = 0;
    m.iqr.clear();
    m.density = "empirical";
    m.bandwidthRule = "";
    m.source = "";
    writeModelVti(dir / "m.vti", m);
    ModelVolume r = readModelVti(dir / "m.vti");
    EXPECT_FALSE(r.hasQuantiles());
    EXPECT_FALSE(r.hasGmm());
    EXPECT_TRUE(r.iqr.empty());
    EXPECT_EQ(r.mean, m.mean);
    EXPECT_EQ(r.bandwidthRule, "");
    EXPECT_EQ(r.source, "");
}

TEST(IoModel, RejectsBadInput) {
    TempDir dir;
    expectUdvrError([&] { readModelVti(dir / "none.vti"); }, {"none.vti", "no such file"});
    ModelVolume m = sampleModel();
    m.quantiles[7] = std::numeric_limits<float>::quiet_NaN();  // voxel 1, boundary 2
    writeModelVti(dir / "nan.vti", m);
    expectUdvrError([&] { readModelVti(dir / "nan.vti"); },
                    {"nan.vti", "1 NaN", "'quantiles'", "(1,0,0)"});
    // A field file is not a model.
    ScalarField f;
    f.grid.dims = {2, 2, 2};
    f.values.assign(8, 1.f);
    f.name = "density";
    writeFieldVti(dir / "field.vti", f);
    expectUdvrError([&] { readModelVti(dir / "field.vti"); },
                    {"field.vti", "no model arrays", "density"});
    // Failing writes leave nothing behind.
    EXPECT_THROW(writeModelVti(dir.path() / "no_dir" / "m.vti", sampleModel()), UdvrError);
    EXPECT_FALSE(std::filesystem::exists(dir.path() / "no_dir"));
}

// ---- files VTK's reader crashes on (issue 15, fuzz/regressions) ---------------------------------

/// `bytes` with the type attribute of the `index`-th array (field data first) replaced.
std::string retyped(std::string bytes, int index, const std::string& type) {
    static const std::regex kType("<(Data)?Array type=\"([A-Za-z0-9]*)\"");
    auto it = std::sregex_iterator(bytes.begin(), bytes.end(), kType);
    for (int i = 0; i < index; ++i) ++it;
    const std::smatch& m = *it;
    return bytes.replace(static_cast<std::size_t>(m.position(2)),
                         static_cast<std::size_t>(m.length(2)), type);
}

/// Every reader of a .vti must fail on `path` with one line holding each of `parts`.
void expectEveryVtiReaderFails(const std::filesystem::path& path,
                               std::initializer_list<std::string> parts) {
    expectUdvrError([&] { readField(path); }, parts);
    expectUdvrError([&] { readModelVti(path); }, parts);
    expectUdvrError([&] { readModelOrField(path); }, parts);
    expectUdvrError([&] { listArrays(path); }, parts);
}

/// Writes `bytes` as dir/name; every reader must fail on it, naming the file and `part`.
void expectRejected(const TempDir& dir, const std::string& name, const std::string& bytes,
                    const std::string& part) {
    writeBytes(dir / name, bytes);
    expectEveryVtiReaderFails(dir / name, {name, part});
}

// VTK 9.1 dereferences a null array (SIGSEGV in `udvr build` and `udvr render`) for a DataArray
// type it does not know, in ParaView's files and udvr's own alike.
TEST(IoVti, UnknownArrayTypesAreErrorsNotCrashes) {
    TempDir dir;
    writeModelVti(dir / "m.vti", sampleModel());
    const std::string model = readBytes(dir / "m.vti");
    for (const std::string type : {"Float-7", "Int999999999", "Float1e308"}) {
        // Field data (quantile_count), point data (mean).
        expectRejected(dir, "fd.vti", retyped(model, 0, type), "has type '" + type + "'");
        expectRejected(dir, "pd.vti", retyped(model, 12, type), "'mean' has type '" + type + "'");
    }
    // VTK reads any element in a data group as an array, whatever its tag.
    std::string misnamed = model;
    const std::string first = "<DataArray type=\"Int32\"";
    misnamed.replace(misnamed.find(first), first.size(), "<DapaArray type=\"Float43\"");
    expectRejected(dir, "tag.vti", misnamed, "'Float43'");
    // Without NumberOfTuples VTK reads a field data array as empty and crashes on its data.
    std::string untold = model;
    untold.erase(untold.find("NumberOfTuples=\"1\""), 18);
    expectRejected(dir, "untold.vti", untold, "'quantile_count' has no NumberOfTuples");
}

/// A model file with the header of its first appended array's data block (compressed: block
/// count, block size, last block size, UInt64 little-endian) overwritten.
std::string withCompressionHeader(std::string bytes, std::uint64_t blocks, std::uint64_t size) {
    const std::size_t at = bytes.find('_', bytes.find("<AppendedData")) + 1;
    std::memcpy(bytes.data() + at, &blocks, 8);
    std::memcpy(bytes.data() + at + 8, &size, 8);
    return bytes;
}

// A block size of 0 divides by zero in VTK (SIGFPE); a block count or block size of 2^60 makes
// it allocate that much.
TEST(IoVti, CompressionHeadersAreChecked) {
    TempDir dir;
    writeModelVti(dir / "m.vti", sampleModel());
    const std::string model = readBytes(dir / "m.vti");
    expectRejected(dir, "zero.vti", withCompressionHeader(model, 1, 0), "block size 0");
    expectRejected(dir, "many.vti", withCompressionHeader(model, std::uint64_t{1} << 60, 32768),
                   "blocks, more than the file holds");
    expectRejected(dir, "huge.vti", withCompressionHeader(model, 0, std::uint64_t{1} << 61),
                   "block size 2305843009213693952");
    // VTK reads an array with an offset from the appended data whatever its format says.
    std::string ascii = withCompressionHeader(model, std::uint64_t{1} << 60, 32768);
    ascii.replace(ascii.find("format=\"appended\""), 17, "format=\"ascii\"   ");
    expectRejected(dir, "ascii.vti", ascii, "blocks, more than the file holds");
}

// A Piece smaller than the WholeExtent leaves points undefined (and VTK leaks on that path); an
// extent of 10^12 points in a small file would be allocated before any data is read.
TEST(IoVti, ExtentsAreChecked) {
    TempDir dir;
    writeWithVtk(dir / "f.vti", Mode::kAppendedRaw, "value");
    std::string bytes = readBytes(dir / "f.vti");
    std::string piece = bytes;
    piece.replace(piece.find("Extent=\"2 6 0 3 1 3\"", piece.find("<Piece")), 20,
                  "Extent=\"2 5 0 3 1 3\"");
    expectRejected(dir, "piece.vti", piece, "Piece extents hold 48 points");
    std::string huge = bytes;
    for (std::size_t p = 0; (p = huge.find("Extent=\"2 6 0 3 1 3\"", p)) != std::string::npos;)
        huge.replace(p, 20, "Extent=\"0 9999 0 9999 0 9999\"");
    expectRejected(dir, "huge.vti", huge, "would hold 1000000000000 values");
}

// The checks accept every encoding VTK writes: a model (with String field data) rewritten by
// VTK appended raw or base64, inline base64 and ascii, uncompressed, zlib and LZ4.
TEST(IoVti, ChecksAcceptEveryVtkEncoding) {
    TempDir dir;
    writeModelVti(dir / "m.vti", sampleModel());
    vtkNew<vtkXMLImageDataReader> reader;
    reader->SetFileName((dir / "m.vti").c_str());
    reader->Update();
    int n = 0;
    for (const int mode : {0, 1, 2, 3})
        for (const int compressor : {0, 1, 2}) {
            const auto path = dir / ("m" + std::to_string(n++) + ".vti");
            vtkNew<vtkXMLImageDataWriter> writer;
            writer->SetFileName(path.c_str());
            writer->SetInputData(reader->GetOutput());
            if (mode == 0) writer->SetDataModeToAscii();
            if (mode == 1) writer->SetDataModeToBinary();
            if (mode >= 2) writer->SetDataModeToAppended();
            writer->SetEncodeAppendedData(mode == 3 ? 1 : 0);
            if (compressor == 0) writer->SetCompressorTypeToNone();
            if (compressor == 1) writer->SetCompressorTypeToZLib();
            if (compressor == 2) writer->SetCompressorTypeToLZ4();
            ASSERT_EQ(writer->Write(), 1);
            const ModelVolume m = readModelVti(path);
            EXPECT_EQ(m.source, "tooth.nhdr --downsample 2") << path;
            EXPECT_EQ(m.quantiles, sampleModel().quantiles) << path;
        }
}

// VTK 9.1 writes every NUL-terminated string of a String array's data into the array, past its
// end when there are more than its tuples (a heap overflow found by fuzzing).
TEST(IoVti, StringArraysHoldTheirTuples) {
    TempDir dir;
    ModelVolume m = sampleModel();
    m.source = "fuzz seed";
    writeModelVti(dir / "m.vti", m);
    std::string bytes = readBytes(dir / "m.vti");
    const std::size_t at = bytes.find("fuzz seed", bytes.find("<AppendedData"));
    ASSERT_NE(at, std::string::npos);  // LZ4 keeps a short string as a literal
    bytes[at + 4] = '\0';
    expectRejected(dir, "two.vti", bytes, "'source': its data holds 2 NUL-terminated strings");
}

// Notes (here: a Direction that is ignored) are printed only once a read succeeded: an error
// stays the one line on stderr.
TEST(IoVti, NoNoteBeforeAnError) {
    TempDir dir;
    writeWithVtk(dir / "f.vti", Mode::kAppendedRaw, "value");
    std::string bytes = readBytes(dir / "f.vti");
    bytes.replace(bytes.find("Direction=\"1 0 0 0 1 0 0 0 1\""), 29,
                  "Direction=\"0 1 0 1 0 0 0 0 1\"");
    writeBytes(dir / "rotated.vti", bytes);
    ::testing::internal::CaptureStderr();
    EXPECT_NO_THROW(readField(dir / "rotated.vti"));
    EXPECT_NE(::testing::internal::GetCapturedStderr().find("Direction"), std::string::npos);
    FieldReadOptions o;
    o.var = "nope";
    ::testing::internal::CaptureStderr();
    expectUdvrError([&] { readField(dir / "rotated.vti", o); }, {"no point array 'nope'"});
    EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
}
}  // namespace
}  // namespace udvr
