#pragma once
// Sorting many short runs at once (build's per-voxel samples): a sorting network applied to
// one run per vector lane. For the 20 samples of a Red Sea voxel this is ~10× cheaper than
// std::sort of each run (docs/building.md, "Timings").
#include <cstddef>
#include <utility>
#include <vector>

namespace udvr {

/// The comparators (i, j), i < j, of Batcher's odd–even merge sort for n elements: the network
/// for the next power of two with every comparator that touches an index ≥ n left out (padding
/// with +∞ there makes those comparators no-ops).
std::vector<std::pair<int, int>> sortingNetwork(int n);

/// Sort `count` runs of n floats ascending in place, run v at data[v·n, (v+1)·n). Values must
/// not be NaN (the order of equal values, +0 and −0 included, is unspecified, as std::sort's).
/// `network`: sortingNetwork(n).
void sortRuns(float* data, std::size_t count, std::size_t n,
              const std::vector<std::pair<int, int>>& network);

}  // namespace udvr
