#pragma once
// Test helpers shared by the 1D and 2D kernel tests: a kernel's lane (CPU batch) and float (one
// GPU thread) bodies against its double body at random points. Test-only.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "udvr/classify/model_kernels.h"
#include "udvr/util/lanes.h"
#include "udvr/util/random.h"

namespace udvr::testing {

// kWidth random index-space points of a grid: inside, on faces and corners, on grid planes and
// outside (clamped).
inline void randomPoints(CounterRng& rng, const std::array<int, 3>& dims, lanes::Vf p[3]) {
    for (int l = 0; l < lanes::kWidth; ++l)
        for (int a = 0; a < 3; ++a) {
            const double m = dims[a] - 1.0, kind = rng.uniform(), u = rng.uniform();
            double v = m * rng.uniform();
            if (kind < 0.2) {  // a face
                v = u < 0.5 ? 0.0 : m;
            } else if (kind < 0.35) {  // outside
                v = u < 0.5 ? -0.6 * u : m + 2.0 * u;
            } else if (kind < 0.45) {  // a grid plane
                v = std::floor(v);
            }
            p[a][l] = static_cast<float>(v);
        }
}

// The worst |lane − double| and |float − double| over the live lanes of `trials` batches of kernel
// k (lanes of cells from cellAt<Vf> at random points, random live masks); lanes that were not live
// must be 0.
template <class K>
inline double worstLaneError(const K& k, CounterRng& rng, const std::array<int, 3>& dims,
                             const std::string& what, int trials = 100) {
    using lanes::Vf;
    double worst = 0.0;
    for (int trial = 0; trial < trials; ++trial) {
        Vf p[3];
        randomPoints(rng, dims, p);
        const lanes::Mask live = trial == 0 ? lanes::allTrue<Vf>()
                                            : lanes::fromBits(static_cast<std::uint32_t>(
                                                  rng.nextBits() & ((1u << lanes::kWidth) - 1u)));
        const Cell<Vf> cell = cellAt<Vf>(k.geometry, p[0], p[1], p[2]);
        Vf got[4];
        k.finish(k.template load<Vf>(cell, live), got);
        for (int l = 0; l < lanes::kWidth; ++l) {
            if (!live[l]) {
                // Kernels that load dead lanes too (kLoadDeadLanes: MeanKernel) classify the
                // value 0 there, TF(0), not 0 as model_kernels.h's contract says; the ray loop
                // masks those lanes itself (Compositor::add with the live mask).
                for (int ch = 0; ch < 4; ++ch)
                    if (!K::kLoadDeadLanes)
                        EXPECT_EQ(got[ch][l], 0.f) << what << " dead lane " << l << " ch " << ch;
                    else
                        EXPECT_TRUE(std::isfinite(got[ch][l])) << what << " dead lane " << l;
                continue;
            }
            double want[4];
            classifyAt<double>(k, p[0][l], p[1][l], p[2][l], want);
            float one[4];  // the "one GPU thread" instantiation
            classifyAt<float>(k, p[0][l], p[1][l], p[2][l], one);
            for (int ch = 0; ch < 4; ++ch) {
                EXPECT_FALSE(std::isnan(got[ch][l])) << what;
                worst = std::max(
                    {worst, std::abs(got[ch][l] - want[ch]), std::abs(one[ch] - want[ch])});
            }
        }
    }
    return worst;
}

}  // namespace udvr::testing
