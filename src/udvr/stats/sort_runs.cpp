#include "udvr/stats/sort_runs.h"

#include <algorithm>

#include "udvr/util/check.h"
#include "udvr/util/lanes.h"

namespace udvr {

std::vector<std::pair<int, int>> sortingNetwork(int n) {
    UDVR_CHECK(n >= 0);
    std::vector<std::pair<int, int>> net;
    int size = 1;
    while (size < n) size *= 2;
    // Batcher (1968), odd–even merge sort, the iterative form (Knuth, TAOCP vol. 3, 5.3.4).
    for (int p = 1; p < size; p *= 2)
        for (int k = p; k >= 1; k /= 2)
            for (int j = k % p; j + k < size; j += 2 * k)
                for (int i = 0; i < std::min(k, size - j - k); ++i)
                    if ((i + j) / (2 * p) == (i + j + k) / (2 * p) && i + j + k < n)
                        net.emplace_back(i + j, i + j + k);
    return net;
}

void sortRuns(float* data, std::size_t count, std::size_t n,
              const std::vector<std::pair<int, int>>& network) {
    using lanes::Vf;
    constexpr std::size_t W = lanes::kWidth;
    if (n < 2 || count == 0) return;
    std::vector<Vf> x(n);  // x[i]: sample i of W runs, one per lane
    std::size_t v = 0;
    for (; v + W <= count; v += W) {
        const float* src = data + v * n;
        for (std::size_t i = 0; i < n; ++i) {
            Vf col;
            for (std::size_t l = 0; l < W; ++l) col[l] = src[l * n + i];
            x[i] = col;
        }
        for (const auto& [a, b] : network) {
            const Vf lo = x[a] < x[b] ? x[a] : x[b];
            const Vf hi = x[a] < x[b] ? x[b] : x[a];
            x[a] = lo;
            x[b] = hi;
        }
        float* dst = data + v * n;
        for (std::size_t i = 0; i < n; ++i)
            for (std::size_t l = 0; l < W; ++l) dst[l * n + i] = x[i][l];
    }
    for (; v < count; ++v) std::sort(data + v * n, data + (v + 1) * n);
}

}  // namespace udvr
