// Every file in the shared real-data folder loads, with the facts its README and headers state.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "udvr/io/ensemble_io.h"
#include "udvr/io/field_io.h"

namespace udvr {
namespace {

namespace fs = std::filesystem;

fs::path dataDir() { return fs::path(UDVR_SHARED_DATA_DIR); }

#define REQUIRE_DATA(sub)                                                            \
    if (!fs::exists(dataDir() / (sub))) {                                            \
        GTEST_SKIP() << "shared data " << (dataDir() / (sub)).string() << " absent"; \
    }

/// Values are whole numbers in [0, 255] (an 8-bit volume read as float).
void expectUint8Values(const ScalarField& f) {
    bool whole = std::all_of(f.values.begin(), f.values.end(),
                             [](float v) { return v >= 0.f && v <= 255.f && v == std::floor(v); });
    EXPECT_TRUE(whole);
    auto [lo, hi] = std::minmax_element(f.values.begin(), f.values.end());
    EXPECT_LT(*lo, *hi);  // not constant
}

TEST(IoSharedData, Uint8Volumes) {
    REQUIRE_DATA("chest-ct");
    ScalarField chest = readField(dataDir() / "chest-ct/chest.nhdr");
    EXPECT_EQ(chest.grid.dims, (std::array<int, 3>{256, 256, 133}));
    EXPECT_EQ(chest.grid.spacing, (std::array<double, 3>{1.40625, 1.40625, 2.5}));
    expectUint8Values(chest);
    EXPECT_EQ(*std::max_element(chest.values.begin(), chest.values.end()), 255.f);

    ScalarField tooth = readField(dataDir() / "tooth/tooth.nhdr");
    EXPECT_EQ(tooth.grid.dims, (std::array<int, 3>{103, 94, 161}));
    EXPECT_EQ(tooth.grid.spacing, (std::array<double, 3>{1, 1, 1}));
    expectUint8Values(tooth);

    ScalarField neghip = readField(dataDir() / "neghip/neghip.nhdr");
    EXPECT_EQ(neghip.grid.dims, (std::array<int, 3>{64, 64, 64}));
    expectUint8Values(neghip);
}

TEST(IoSharedData, IsabelWindSpeedVti) {
    REQUIRE_DATA("isabel-windspeed");
    ScalarField f = readField(dataDir() / "isabel-windspeed/windspeed_t02.vti");
    EXPECT_EQ(f.name, "velocityMag");
    EXPECT_EQ(f.grid.dims, (std::array<int, 3>{125, 125, 25}));
    EXPECT_DOUBLE_EQ(f.grid.spacing[0], 4.0080321286);
    EXPECT_DOUBLE_EQ(f.grid.spacing[2], 4.0408163266);
    auto [lo, hi] = std::minmax_element(f.values.begin(), f.values.end());
    EXPECT_EQ(*lo, 0.f);
    EXPECT_EQ(*hi, static_cast<float>(68.245477692));  // the header's RangeMax, to float32
    for (const char* t : {"t03", "t04", "t05"}) {
        ScalarField g =
            readField(dataDir() / (std::string("isabel-windspeed/windspeed_") + t + ".vti"));
        EXPECT_EQ(g.grid.dims, f.grid.dims);
    }
}

TEST(IoSharedData, FuelEnsembleNetcdfMatchesMemberFiles) {
    REQUIRE_DATA("fuel-ensemble");
    ::testing::internal::CaptureStderr();
    Ensemble nc = readEnsemble({(dataDir() / "fuel-ensemble/fuel_ensemble.nc").string()}, {});
    ::testing::internal::GetCapturedStderr();
    Ensemble files =
        readEnsemble({(dataDir() / "fuel-ensemble/members/member_*.nhdr").string()}, {});
    EXPECT_EQ(nc.name, "fuel");
    EXPECT_EQ(nc.members, 10);
    EXPECT_EQ(files.members, 10);
    EXPECT_EQ(nc.grid.dims, (std::array<int, 3>{64, 64, 64}));
    EXPECT_EQ(files.grid.dims, nc.grid.dims);
    EXPECT_EQ(files.grid.spacing, nc.grid.spacing);
    EXPECT_EQ(files.grid.origin, nc.grid.origin);
    EXPECT_TRUE(files.values == nc.values);  // identical, member by member in natural order
}

}  // namespace
}  // namespace udvr
