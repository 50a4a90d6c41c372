#include "udvr/stats/sort_runs.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "udvr/util/random.h"

namespace udvr {

TEST(SortRuns, NetworkSortsEveryZeroOneInputForSmallN) {
    // The 0–1 principle (Knuth 5.3.4): a network that sorts all 2^n 0–1 inputs sorts everything.
    for (int n = 1; n <= 14; ++n) {
        const auto net = sortingNetwork(n);
        for (std::uint32_t bits = 0; bits < (1u << n); ++bits) {
            std::vector<int> a(static_cast<std::size_t>(n));
            for (int i = 0; i < n; ++i) a[static_cast<std::size_t>(i)] = (bits >> i) & 1;
            for (const auto& [i, j] : net) {
                ASSERT_LT(i, j);
                ASSERT_LT(j, n);
                if (a[static_cast<std::size_t>(i)] > a[static_cast<std::size_t>(j)])
                    std::swap(a[static_cast<std::size_t>(i)], a[static_cast<std::size_t>(j)]);
            }
            ASSERT_TRUE(std::is_sorted(a.begin(), a.end())) << n << " " << bits;
        }
    }
}

TEST(SortRuns, MatchesStdSortOnRandomRunsWithTies) {
    for (int n : {1, 2, 3, 5, 8, 13, 20, 31, 32, 33, 50, 64, 100}) {
        const auto net = sortingNetwork(n);
        for (std::size_t count : {std::size_t{1}, std::size_t{7}, std::size_t{16}, std::size_t{37},
                                  std::size_t{1024}}) {
            const std::size_t un = static_cast<std::size_t>(n);
            std::vector<float> data(count * un);
            for (std::size_t i = 0; i < data.size(); ++i) {
                CounterRng rng(7, i, un);
                const double u = rng.uniform();
                // Ties (a few values only), infinities and ordinary values.
                data[i] = u < 0.3    ? static_cast<float>(static_cast<int>(u * 10))
                          : u < 0.32 ? (u < 0.31 ? -1.f : 1.f) * 1e38f * 10.f
                                     : static_cast<float>(rng.normal());
            }
            std::vector<float> expected = data;
            for (std::size_t v = 0; v < count; ++v)
                std::sort(expected.begin() + static_cast<std::ptrdiff_t>(v * un),
                          expected.begin() + static_cast<std::ptrdiff_t>((v + 1) * un));
            sortRuns(data.data(), count, un, net);
            ASSERT_EQ(data, expected) << n << " " << count;
        }
    }
}

}  // namespace udvr
