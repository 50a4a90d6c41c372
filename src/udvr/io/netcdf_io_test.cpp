// NetCDF fields and ensembles: files written with the netCDF C API here, our writers read back,
// geometry from CF coordinate variables, and bad input.
#include <gtest/gtest.h>
#include <netcdf.h>

#include <cmath>
#include <limits>
#include <optional>
#include <thread>

#include "udvr/io/ensemble_io.h"
#include "udvr/io/field_io.h"
#include "udvr/io/file_info.h"
#include "udvr/io/io_detail.h"
#include "udvr/io/io_test_util.h"

namespace udvr {
namespace {

using testing::expectUdvrError;
using testing::TempDir;

#define NC_OK(call)                                                 \
    do {                                                            \
        int nc_status_ = (call);                                    \
        ASSERT_EQ(nc_status_, NC_NOERR) << nc_strerror(nc_status_); \
    } while (0)

struct NcSpec {
    std::vector<std::string> dimNames{"z", "y", "x"};
    std::vector<std::size_t> dimLengths{2, 3, 4};
    std::string var = "temperature";
    nc_type type = NC_DOUBLE;
    std::vector<double> values;  // empty: v = i + 10j + 100k (+ 1000·member for 4D)
    // Coordinates per dim name written as a coordinate variable (absent = not written).
    std::vector<std::pair<std::string, std::vector<double>>> coords;
    bool secondVar = false;
};

std::vector<double> rampValues(const NcSpec& s) {
    std::vector<double> v;
    std::size_t total = 1;
    for (auto l : s.dimLengths) total *= l;
    std::size_t nx = s.dimLengths.back(), ny = s.dimLengths[s.dimLengths.size() - 2];
    std::size_t nz = s.dimLengths[s.dimLengths.size() - 3];
    for (std::size_t p = 0; p < total; ++p) {
        std::size_t i = p % nx, j = (p / nx) % ny, k = (p / (nx * ny)) % nz, m = p / (nx * ny * nz);
        v.push_back(double(i + 10 * j + 100 * k + 1000 * m));
    }
    return v;
}

void writeNc(const std::filesystem::path& path, const NcSpec& s) {
    int nc = -1;
    NC_OK(nc_create(path.c_str(), NC_CLOBBER | NC_NETCDF4, &nc));
    std::vector<int> dims;
    for (std::size_t d = 0; d < s.dimNames.size(); ++d) {
        int id;
        NC_OK(nc_def_dim(nc, s.dimNames[d].c_str(), s.dimLengths[d], &id));
        dims.push_back(id);
    }
    std::vector<std::pair<int, const std::vector<double>*>> coordVars;
    for (const auto& [name, values] : s.coords) {
        int d = -1, id = -1;
        NC_OK(nc_inq_dimid(nc, name.c_str(), &d));
        NC_OK(nc_def_var(nc, name.c_str(), NC_FLOAT, 1, &d, &id));
        coordVars.emplace_back(id, &values);
    }
    int var = -1;
    NC_OK(nc_def_var(nc, s.var.c_str(), s.type, int(dims.size()), dims.data(), &var));
    int var2 = -1;
    if (s.secondVar) {
        NC_OK(nc_def_var(nc, "pressure", s.type, int(dims.size()), dims.data(), &var2));
    }
    NC_OK(nc_enddef(nc));
    for (const auto& [id, values] : coordVars) NC_OK(nc_put_var_double(nc, id, values->data()));
    std::vector<double> v = s.values.empty() ? rampValues(s) : s.values;
    NC_OK(nc_put_var_double(nc, var, v.data()));
    if (s.secondVar) {
        NC_OK(nc_put_var_double(nc, var2, v.data()));
    }
    NC_OK(nc_close(nc));
}

TEST(IoNetcdf, ReadsFieldWithCoordinates) {
    TempDir dir;
    NcSpec s;
    s.coords = {{"x", {1.0, 1.5, 2.0, 2.5}}, {"y", {-3, -1, 1}}, {"z", {0.1f, 0.4f}}};
    s.type = NC_SHORT;
    writeNc(dir / "f.nc", s);
    ScalarField f = readField(dir / "f.nc");
    EXPECT_EQ(f.name, "temperature");
    ASSERT_EQ(f.grid.dims, (std::array<int, 3>{4, 3, 2}));
    EXPECT_EQ(f.values[f.grid.index(3, 2, 1)], 123.f);
    EXPECT_DOUBLE_EQ(f.grid.origin[0], 1.0);
    EXPECT_DOUBLE_EQ(f.grid.spacing[0], 0.5);
    EXPECT_DOUBLE_EQ(f.grid.origin[1], -3.0);
    EXPECT_DOUBLE_EQ(f.grid.spacing[1], 2.0);
    EXPECT_NEAR(f.grid.spacing[2], 0.3, 1e-6);
}

// The quantisation step: 1 for integer variables, |scale_factor| for CF-packed ones, 0 for floats.
TEST(IoNetcdf, ValueTypeAndStepFollowTypeAndPacking) {
    TempDir dir;
    NcSpec s;
    s.type = NC_SHORT;
    writeNc(dir / "i.nc", s);
    ScalarField f = readField(dir / "i.nc");
    EXPECT_EQ(f.valueType, "int16");
    EXPECT_EQ(f.valueStep, 1.0);
    s.type = NC_FLOAT;
    writeNc(dir / "f.nc", s);
    f = readField(dir / "f.nc");
    EXPECT_EQ(f.valueType, "float32");
    EXPECT_EQ(f.valueStep, 0.0);
    int nc = -1, var = -1;
    s.type = NC_SHORT;
    writeNc(dir / "p.nc", s);
    NC_OK(nc_open((dir / "p.nc").c_str(), NC_WRITE, &nc));
    NC_OK(nc_inq_varid(nc, "temperature", &var));
    NC_OK(nc_redef(nc));
    const double scale = -0.25, offset = 3.0;
    NC_OK(nc_put_att_double(nc, var, "scale_factor", NC_DOUBLE, 1, &scale));
    NC_OK(nc_put_att_double(nc, var, "add_offset", NC_DOUBLE, 1, &offset));
    NC_OK(nc_close(nc));
    f = readField(dir / "p.nc");
    EXPECT_EQ(f.valueType, "int16");
    EXPECT_EQ(f.valueStep, 0.25);
    EXPECT_EQ(f.values[f.grid.index(3, 2, 1)], 123.f * -0.25f + 3.f);
}

TEST(IoNetcdf, MissingCoordinatesGiveUnitGridWithANote) {
    TempDir dir;
    NcSpec s;
    s.dimNames = {"time", "lev", "lat", "lon"};  // any names; a length-1 leading dim is fine
    s.dimLengths = {1, 2, 3, 4};
    writeNc(dir / "f.nc", s);
    ::testing::internal::CaptureStderr();
    ScalarField f = readField(dir / "f.nc");
    std::string err = ::testing::internal::GetCapturedStderr();
    EXPECT_NE(err.find("no coordinate variables for lon, lat, lev"), std::string::npos) << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1);
    EXPECT_EQ(f.grid.origin, (std::array<double, 3>{0, 0, 0}));
    EXPECT_EQ(f.grid.spacing, (std::array<double, 3>{1, 1, 1}));
    EXPECT_EQ(f.values[f.grid.index(3, 2, 1)], 123.f);
}

TEST(IoNetcdf, FieldWriterRoundTrip) {
    TempDir dir;
    ScalarField f;
    f.grid.dims = {5, 3, 2};
    f.grid.origin = {-2.5, 0.0, 10.0};
    f.grid.spacing = {0.1, 0.7, 3.0};
    f.name = "x";  // clashes with the coordinate variable: written under another name
    for (std::size_t i = 0; i < f.grid.pointCount(); ++i) f.values.push_back(float(i) * 0.25f);
    writeField(dir / "f.nc", f);
    EXPECT_EQ(testing::fileCount(dir.path()), 1u);
    ScalarField g = readField(dir / "f.nc");
    EXPECT_EQ(g.name, "x_value");
    EXPECT_EQ(g.grid.dims, f.grid.dims);
    EXPECT_EQ(g.values, f.values);
    for (int a = 0; a < 3; ++a) {
        EXPECT_NEAR(g.grid.origin[a], f.grid.origin[a], 1e-12);
        EXPECT_NEAR(g.grid.spacing[a], f.grid.spacing[a], 1e-12);
    }
}

TEST(IoNetcdf, RejectsBadInput) {
    TempDir dir;
    NcSpec s;
    s.coords = {{"x", {0, 1, 3, 4}}};
    writeNc(dir / "uneven.nc", s);
    expectUdvrError([&] { readField(dir / "uneven.nc"); }, {"uneven.nc", "x", "unevenly spaced"});

    NcSpec two;
    two.secondVar = true;
    writeNc(dir / "two.nc", two);
    expectUdvrError([&] { readField(dir / "two.nc"); }, {"two.nc", "several", "--var"});
    FieldReadOptions o;
    o.var = "pressure";
    EXPECT_EQ(readField(dir / "two.nc", o).name, "pressure");
    o.var = "wind";
    expectUdvrError([&] { readField(dir / "two.nc", o); }, {"two.nc", "no variable 'wind'"});

    NcSpec nan;
    nan.values = rampValues(nan);
    nan.values[13] = std::numeric_limits<double>::quiet_NaN();
    nan.values[14] = std::numeric_limits<double>::infinity();
    writeNc(dir / "nan.nc", nan);
    expectUdvrError([&] { readField(dir / "nan.nc"); }, {"nan.nc", "1 NaN and 1 Inf", "(1,0,1)"});

    NcSpec ens;
    ens.dimNames = {"member", "z", "y", "x"};
    ens.dimLengths = {3, 2, 3, 4};
    writeNc(dir / "ens.nc", ens);
    expectUdvrError(
        [&] { readField(dir / "ens.nc"); },
        {"ens.nc", "holds a 3-member ensemble", "'temperature'", "member,z,y,x", "udvr build"});
    try {
        readField(dir / "ens.nc");
        ADD_FAILURE() << "expected an EnsembleNotFieldError";
    } catch (const EnsembleNotFieldError& e) {
        EXPECT_EQ(e.members, 3);
        EXPECT_EQ(e.var, "temperature");
        EXPECT_EQ(e.dims, "member,z,y,x");
    }
    o.var = "temperature";
    EXPECT_THROW(readField(dir / "ens.nc", o), EnsembleNotFieldError);

    testing::writeBytes(dir / "text.nc", "CDF? no, just text");
    expectUdvrError([&] { readField(dir / "text.nc"); }, {"text.nc", "NetCDF"});
    // A classic file cut short.
    ScalarField f;
    f.grid.dims = {8, 8, 8};
    f.values.assign(512, 1.f);
    writeFieldNetcdf(dir / "full.nc", f);
    std::string bytes = testing::readBytes(dir / "full.nc");
    testing::writeBytes(dir / "cut.nc", bytes.substr(0, bytes.size() - 1000));
    expectUdvrError([&] { readField(dir / "cut.nc"); }, {"cut.nc"});

    // A NetCDF-4 (HDF5) file cut short: its superblock's end-of-file address says so; cut inside
    // the superblock, or damaged further in, it is still named truncated or damaged.
    NcSpec big;
    big.dimLengths = {8, 8, 8};
    writeNc(dir / "full4.nc", big);
    bytes = testing::readBytes(dir / "full4.nc");
    testing::writeBytes(dir / "cut4.nc", bytes.substr(0, bytes.size() / 2));
    expectUdvrError([&] { readField(dir / "cut4.nc"); },
                    {"cut4.nc", "truncated NetCDF-4/HDF5 file",
                     "expected " + std::to_string(bytes.size()) + " bytes"});
    testing::writeBytes(dir / "head4.nc", bytes.substr(0, 20));
    expectUdvrError([&] { readField(dir / "head4.nc"); }, {"head4.nc", "truncated or damaged"});
    std::string damaged = bytes;
    for (std::size_t i = 100; i < damaged.size(); ++i) damaged[i] = '\x5a';
    testing::writeBytes(dir / "damaged4.nc", damaged);
    expectUdvrError([&] { readField(dir / "damaged4.nc"); },
                    {"damaged4.nc", "truncated or damaged"});
}

// netCDF-C allocates what a classic header's counts ask for (found by fuzzing: a name of 2^62
// bytes, a variable of 2^31 dimensions); the counts are checked against the file first, for
// streaming files (record count -1) too.
TEST(IoNetcdf, ClassicHeaderCountsAreCheckedBeforeOpening) {
    TempDir dir;
    ScalarField f;
    f.grid.dims = {4, 3, 2};
    f.values.assign(24, 1.f);
    f.name = "tangle";
    writeFieldNetcdf(dir / "f.nc", f);
    const std::string bytes = testing::readBytes(dir / "f.nc");
    ASSERT_EQ(bytes.substr(0, 4), std::string("CDF\x02", 4));
    // CDF-2: magic, numrecs (4 bytes), NC_DIMENSION (4 bytes), the number of dimensions.
    for (const bool streaming : {false, true}) {
        std::string bad = bytes;
        if (streaming) bad.replace(4, 4, "\xff\xff\xff\xff");
        bad.replace(12, 4, "\x7f\xff\xff\xff");
        testing::writeBytes(dir / "count.nc", bad);
        expectUdvrError([&] { readField(dir / "count.nc"); },
                        {"count.nc", "truncated NetCDF header"});
    }
    // A variable type code netCDF-C does not know: it divides by its size of 0 (SIGFPE).
    const std::size_t header = bytes.find("tangle") + 64;  // the data variable's entry
    const std::size_t type = bytes.rfind(std::string("\0\0\0\x05", 4), header);  // NC_FLOAT
    ASSERT_NE(type, std::string::npos);
    std::string bad = bytes;
    bad[type + 3] = '\x0c';
    testing::writeBytes(dir / "type.nc", bad);
    expectUdvrError([&] { readField(dir / "type.nc"); },
                    {"type.nc", "type code 12 is not a NetCDF type"});
}

// A dimension of length 0 tripped an internal check (found by fuzzing); dims whose product
// overflows size_t would size the buffer netCDF-C writes into with the wrapped product.
TEST(IoNetcdf, EmptyAndHugeDimensionsAreErrors) {
    TempDir dir;
    int nc = -1, dims[3], var = -1;
    NC_OK(nc_create((dir / "empty.nc").c_str(), NC_CLOBBER | NC_64BIT_OFFSET, &nc));
    NC_OK(nc_def_dim(nc, "z", NC_UNLIMITED, &dims[0]));
    NC_OK(nc_def_dim(nc, "y", 3, &dims[1]));
    NC_OK(nc_def_dim(nc, "x", 4, &dims[2]));
    NC_OK(nc_def_var(nc, "v", NC_FLOAT, 3, dims, &var));
    NC_OK(nc_close(nc));
    expectUdvrError([&] { readField(dir / "empty.nc"); },
                    {"empty.nc", "dimension z of variable v has length 0"});

    // 2^57 values, never written (NetCDF-4 stores no data for them).
    NC_OK(nc_create((dir / "huge.nc").c_str(), NC_CLOBBER | NC_NETCDF4, &nc));
    NC_OK(nc_def_dim(nc, "z", std::size_t{1} << 17, &dims[0]));
    NC_OK(nc_def_dim(nc, "y", std::size_t{1} << 20, &dims[1]));
    NC_OK(nc_def_dim(nc, "x", std::size_t{1} << 20, &dims[2]));
    NC_OK(nc_def_var(nc, "v", NC_FLOAT, 3, dims, &var));
    NC_OK(nc_close(nc));
    expectUdvrError([&] { readField(dir / "huge.nc"); },
                    {"huge.nc", "dims 1048576x1048576x131072 are too large"});
}

// nc_open fails on this damaged NetCDF-4 file but leaves it open in HDF5, and a second read of
// it in the same process (`info`, then the data) crashed in H5HG_read (found by fuzzing).
TEST(IoNetcdf, SecondReadOfAFileHdf5FailedOnIsTheSameError) {
    const std::filesystem::path file = std::filesystem::path(UDVR_FUZZ_REGRESSIONS_DIR) / "netcdf" /
                                       "netcdf4-reopen-after-failed-open-h5hg-memcpy";
    TempDir dir;
    std::filesystem::copy_file(file, dir / "bad.nc");
    for (int i = 0; i < 3; ++i) {
        expectUdvrError([&] { readField(dir / "bad.nc"); }, {"bad.nc", "NetCDF: HDF error"});
        expectUdvrError([&] { readEnsemble({(dir / "bad.nc").string()}, {}); },
                        {"bad.nc", "NetCDF: HDF error"});
        expectUdvrError([&] { listArrays(dir / "bad.nc"); }, {"bad.nc", "NetCDF: HDF error"});
    }
}

// HDF5 1.10.8 loops forever on this damaged NetCDF-4 file (found by fuzzing); a child process
// tries the library calls first and gives up after 10 s (here 0.5 s).
TEST(IoNetcdf, Hdf5HangBecomesAnError) {
    detail::setHdf5ProbeSeconds(0.5);
    const std::filesystem::path file = std::filesystem::path(UDVR_FUZZ_REGRESSIONS_DIR) / "netcdf" /
                                       "netcdf4-hdf5-global-heap-loop";
    TempDir dir;
    std::filesystem::copy_file(file, dir / "loop.nc");
    expectUdvrError(
        [&] { readField(dir / "loop.nc"); },
        {"loop.nc", "the HDF5 library did not finish reading this NetCDF-4 file", "within 0.5 s"});
    detail::setHdf5ProbeSeconds(10.0);
}

// netCDF-C and HDF5 are not thread-safe and each NetCDF-4 read forks an HDF5 probe: reads from
// several threads at once (Python with the GIL released, the server) take turns on one lock and
// fork only while holding it, so every read sees its own file whole (netcdfLibraryMutex).
TEST(IoNetcdf, ThreadsReadingAtOnceEachGetTheirFile) {
    TempDir dir;
    for (int f = 0; f < 4; ++f) {
        NcSpec s;
        s.dimLengths = {6, 7, 8};
        s.values = rampValues(s);
        for (double& v : s.values) v += 10000.0 * f;
        writeNc(dir / ("f" + std::to_string(f) + ".nc"), s);
    }
    std::vector<std::thread> threads;
    std::vector<int> wrong(4, 0);
    for (int t = 0; t < 4; ++t)
        threads.emplace_back([&, t] {
            for (int r = 0; r < 12; ++r) {
                const int f = (t + r) % 4;
                const auto path = dir / ("f" + std::to_string(f) + ".nc");
                try {  // without the lock: "NetCDF: HDF error" on a sound file, 3 runs of 3
                    const ScalarField field = readField(path);
                    wrong[t] += field.values[field.grid.index(7, 6, 5)] !=
                                10000.f * static_cast<float>(f) + 567.f;
                    wrong[t] += listArrays(path).size() != 1;
                } catch (const UdvrError&) {
                    ++wrong[t];
                }
            }
        });
    for (auto& t : threads) t.join();
    EXPECT_EQ(wrong, std::vector<int>(4, 0));
}

TEST(IoNetcdf, EnsembleFromMemberDimension) {
    TempDir dir;
    NcSpec s;
    s.dimNames = {"realization", "z", "y", "x"};
    s.dimLengths = {3, 2, 3, 4};
    s.var = "fuel";
    s.type = NC_FLOAT;
    s.coords = {{"x", {0, 2, 4, 6}}, {"y", {0, 2, 4}}, {"z", {5, 7}}};
    writeNc(dir / "e.nc", s);
    Ensemble e = readEnsemble({(dir / "e.nc").string()}, {});
    EXPECT_EQ(e.members, 3);
    EXPECT_EQ(e.name, "fuel");
    ASSERT_EQ(e.grid.dims, (std::array<int, 3>{4, 3, 2}));
    EXPECT_EQ(e.grid.spacing, (std::array<double, 3>{2, 2, 2}));
    EXPECT_EQ(e.grid.origin, (std::array<double, 3>{0, 0, 5}));
    EXPECT_EQ(e.member(2)[e.grid.index(3, 2, 1)], 2123.f);
    EXPECT_EQ(e.member(0)[e.grid.index(1, 0, 0)], 1.f);

    // A member dimension with another name, named by the caller; and a member dim not first.
    s.dimNames = {"z", "y", "x", "sample"};
    s.dimLengths = {2, 3, 4, 2};
    s.coords.clear();
    writeNc(dir / "last.nc", s);
    expectUdvrError([&] { readEnsemble({(dir / "last.nc").string()}, {}); },
                    {"last.nc", "no variable with a member dimension"});
    EnsembleReadOptions o;
    o.memberDim = "sample";
    ::testing::internal::CaptureStderr();
    Ensemble l = readEnsemble({(dir / "last.nc").string()}, o);
    ::testing::internal::GetCapturedStderr();
    ASSERT_EQ(l.members, 2);
    ASSERT_EQ(l.grid.dims, (std::array<int, 3>{4, 3, 2}));
    // rampValues counts the last dim (here the member) fastest.
    EXPECT_EQ(l.member(1)[0], 1.f);
    EXPECT_EQ(l.member(0)[1], 10.f);
}

TEST(IoNetcdf, EnsembleWriterRoundTripAndBadInput) {
    TempDir dir;
    Ensemble e;
    e.grid.dims = {4, 3, 2};
    e.grid.origin = {1, 2, 3};
    e.grid.spacing = {0.5, 0.5, 0.25};
    e.members = 3;
    e.name = "";
    for (std::size_t i = 0; i < 3 * e.grid.pointCount(); ++i) e.values.push_back(float(i));
    writeEnsembleNetcdf(dir / "e.nc", e);
    Ensemble r = readEnsemble({(dir / "e.nc").string()}, {});
    EXPECT_EQ(r.name, "value");
    EXPECT_EQ(r.members, 3);
    EXPECT_EQ(r.values, e.values);
    EXPECT_EQ(r.grid.origin, e.grid.origin);
    EXPECT_EQ(r.grid.spacing, e.grid.spacing);

    e.members = 1;
    e.values.resize(e.grid.pointCount());
    writeEnsembleNetcdf(dir / "one.nc", e);
    expectUdvrError([&] { readEnsemble({(dir / "one.nc").string()}, {}); },
                    {"one.nc", "1 member", "at least 2"});

    NcSpec nan;
    nan.dimNames = {"member", "z", "y", "x"};
    nan.dimLengths = {2, 2, 3, 4};
    nan.values = rampValues(nan);
    nan.values[24 + 5] = std::numeric_limits<double>::quiet_NaN();
    writeNc(dir / "nan.nc", nan);
    expectUdvrError([&] { readEnsemble({(dir / "nan.nc").string()}, {}); },
                    {"nan.nc", "1 NaN", "member 1", "(1,1,0)"});
    EXPECT_THROW(writeEnsembleNetcdf(dir.path() / "missing_dir" / "e.nc", r), UdvrError);
}

}  // namespace
}  // namespace udvr
