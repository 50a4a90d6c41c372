#include "udvr/util/normal_cdf.h"

#include <gtest/gtest.h>

#include <cmath>

namespace udvr {

// Reference: the C library's erfc (correctly rounded to within a few ulp).
TEST(NormalCdf, MatchesStdErfcEverywhere) {
    double maxErr = 0.0, maxPdfErr = 0.0;
    for (int i = -400000; i <= 400000; ++i) {
        const double u = i * 1e-4 * 4.0;  // u in [-40, 40]
        const NormalCdfPdf r = normalCdfPdf(u);
        const double cdf = 0.5 * std::erfc(-u / std::sqrt(2.0));
        const double pdf = std::exp(-0.5 * u * u) / std::sqrt(2.0 * M_PI);
        maxErr = std::max(maxErr, std::fabs(r.cdf - cdf));
        maxPdfErr = std::max(maxPdfErr, std::fabs(r.pdf - pdf));
    }
    EXPECT_LT(maxErr, 1e-9);
    EXPECT_LT(maxPdfErr, 1e-15);
}

// The upper tail keeps its relative precision far out (where 1 − Φ would be 0 or noise).
TEST(NormalCdf, UpperTailIsRelativelyAccurate) {
    for (double u = -8.0; u <= 30.0; u += 1.0 / 64.0) {
        const double want = 0.5 * std::erfc(u / std::sqrt(2.0));
        const NormalCdfPdf r = normalCdfPdf(u);
        EXPECT_NEAR(r.upper, want, u > 0 ? 2e-9 * want : 1e-9) << u;
        EXPECT_NEAR(r.upper + r.cdf, 1.0, 1e-15) << u;
    }
}

TEST(NormalCdf, ErfAndErfcMatchStd) {
    for (double x = -8.0; x <= 8.0; x += 1.0 / 1024.0) {
        EXPECT_NEAR(fastErf(x), std::erf(x), 2e-9) << x;
        EXPECT_NEAR(fastErfc(x), std::erfc(x), 2e-9) << x;
    }
}

TEST(NormalCdf, LimitsAndSymmetry) {
    EXPECT_NEAR(normalCdf(0.0), 0.5, 1e-9);
    EXPECT_EQ(normalCdf(-60.0), 0.0);
    EXPECT_EQ(normalCdf(60.0), 1.0);
    for (double u = 0.0; u < 10.0; u += 0.37) EXPECT_NEAR(normalCdf(u) + normalCdf(-u), 1.0, 2e-9);
}

}  // namespace udvr
