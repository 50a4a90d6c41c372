// checkModelArrays: what no model holds is an error naming the array and the voxel (issue 34).
#include "udvr/stats/model_volume.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "udvr/util/check.h"

namespace udvr {
namespace {

/// A valid 3×2×2 model with q = 2 and K = 1.
ModelVolume validModel() {
    ModelVolume m;
    m.grid.dims = {3, 2, 2};
    const std::size_t n = m.voxelCount();
    m.mean.assign(n, 1.f);
    m.stddev.assign(n, 0.5f);
    m.min.assign(n, 0.f);
    m.max.assign(n, 2.f);
    m.quantileCount = 2;
    for (std::size_t v = 0; v < n; ++v) m.quantiles.insert(m.quantiles.end(), {0.f, 1.f, 2.f});
    for (std::size_t v = 0; v < n; ++v) m.iqr.insert(m.iqr.end(), {0.5f, 1.5f});
    m.gmmComponents = 1;
    for (std::size_t v = 0; v < n; ++v) m.gmm.insert(m.gmm.end(), {1.f, 1.f, 0.5f});
    return m;
}

std::string errorOf(const ModelVolume& m) {
    try {
        checkModelArrays(m, "m.vti");
    } catch (const UdvrError& e) {
        return e.what();
    }
    return "";
}

TEST(ModelVolume, CheckModelArraysAcceptsABuiltModel) { EXPECT_EQ(errorOf(validModel()), ""); }

TEST(ModelVolume, CheckModelArraysNamesArrayAndVoxel) {
    const std::size_t v = 1 + 3 * (1 + 2 * 1);  // voxel (1, 1, 1)
    struct Case {
        void (*change)(ModelVolume&, std::size_t);
        const char* expected;
    };
    const Case cases[] = {
        {[](ModelVolume& m, std::size_t i) { m.stddev[i] = -0.5f; },
         "m.vti: array 'stddev' is negative (-0.5) at voxel (1, 1, 1)"},
        {[](ModelVolume& m, std::size_t i) { m.stddev[i] = 3e38f; },
         "m.vti: array 'stddev' is 3e+38, over 1e+18 at voxel (1, 1, 1)"},
        {[](ModelVolume& m, std::size_t i) { m.mean[i] = std::nanf(""); },
         "m.vti: array 'mean' holds NaN at voxel (1, 1, 1)"},
        {[](ModelVolume& m, std::size_t i) {
             m.quantiles[3 * i + 1] = std::numeric_limits<float>::infinity();
         },
         "m.vti: array 'quantiles' holds Inf (component 1) at voxel (1, 1, 1)"},
        {[](ModelVolume& m, std::size_t i) { m.quantiles[3 * i + 2] = 0.5f; },
         "m.vti: array 'quantiles' decreases: boundary 2 (0.5) is below boundary 1 (1) at voxel "
         "(1, 1, 1)"},
        {[](ModelVolume& m, std::size_t i) { m.iqr[2 * i] = 3.f; },
         "m.vti: array 'iqr' decreases: boundary 1 (1.5) is below boundary 0 (3) at voxel "
         "(1, 1, 1)"},
        {[](ModelVolume& m, std::size_t i) { m.min[i] = 5.f; },
         "m.vti: array 'min' is 5, over max 2 at voxel (1, 1, 1)"},
        {[](ModelVolume& m, std::size_t i) { m.gmm[3 * i] = -0.25f; },
         "m.vti: array 'gmm' component 0 weight is -0.25, outside [0, 1] at voxel (1, 1, 1)"},
        {[](ModelVolume& m, std::size_t i) { m.gmm[3 * i + 2] = -1.f; },
         "m.vti: array 'gmm' component 0 sigma is negative (-1) at voxel (1, 1, 1)"},
    };
    for (const Case& c : cases) {
        ModelVolume m = validModel();
        c.change(m, v);
        EXPECT_EQ(errorOf(m), c.expected);
    }
}

}  // namespace
}  // namespace udvr
