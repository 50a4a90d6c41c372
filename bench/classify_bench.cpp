// Classification cost per sample (reconstruct + expected TF) for every model at q = 2, 4, 8, 16,
// one core, on a random 32³ model volume with a tangle-like TF (docs/models.md has the table):
// the exact body (classifyAt<double>, the probe's path) and the lane body the ray loop runs
// (load<Vf>/finish on a batch of lanes::kWidth samples).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "udvr/classify/model_families.h"
#include "udvr/classify/model_kernels.h"
#include "udvr/util/lanes.h"
#include "udvr/util/random.h"

namespace {

using namespace udvr;

ModelVolume benchModel(int q) {
    const int n = 32;
    ModelVolume m;
    m.grid.dims = {n, n, n};
    m.quantileCount = q;
    m.gmmComponents = 4;
    CounterRng rng(1234, static_cast<std::uint64_t>(q), 0);
    std::vector<double> s(32);
    m.memberCount = static_cast<int>(s.size());  // the samples, as drawn, are the members
    const double ns = static_cast<double>(s.size());
    for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                const double c = 10.0 * std::sin(0.3 * i) * std::cos(0.2 * j) + 0.3 * k - 5.0;
                for (auto& x : s) x = c + (rng.uniform() < 0.3 ? -2.0 : 1.0) + rng.normal();
                for (double x : s) m.members.push_back(static_cast<float>(x));
                std::sort(s.begin(), s.end());
                double mean = 0, var = 0;
                for (double x : s) mean += x / ns;
                for (double x : s) var += (x - mean) * (x - mean) / (ns - 1);
                m.mean.push_back(static_cast<float>(mean));
                m.stddev.push_back(static_cast<float>(std::sqrt(var)));
                m.min.push_back(static_cast<float>(s.front()));
                m.max.push_back(static_cast<float>(s.back()));
                for (int b = 0; b <= q; ++b) {
                    const double pos = double(b) / q * (ns - 1);
                    const std::size_t lo =
                        std::min<std::size_t>(static_cast<std::size_t>(pos), s.size() - 2);
                    m.quantiles.push_back(static_cast<float>(
                        s[lo] + (pos - static_cast<double>(lo)) * (s[lo + 1] - s[lo])));
                }
                m.iqr.push_back(m.quantiles[m.quantiles.size() - 1 - 3 * q / 4]);
                m.iqr.push_back(m.quantiles[m.quantiles.size() - 1 - q / 4]);
                for (int g = 0; g < 4; ++g) m.gmm.push_back(0.25f);
                for (int g = 0; g < 4; ++g) m.gmm.push_back(static_cast<float>(mean - 3 + 2 * g));
                for (int g = 0; g < 4; ++g) m.gmm.push_back(0.5f);
            }
    return m;
}

TransferFunction1D benchTf() {
    TransferFunction1D tf;
    tf.colorX = {-15, -4.5, -2, 0, 1.5, 3, 25};
    tf.color = {{0.7, 0.05, 0.05}, {0.85, 0.1, 0.1},   {0.95, 0.55, 0.1}, {1, 0.8, 0.2},
                {0.6, 0.8, 0.8},   {0.25, 0.45, 0.95}, {0.1, 0.2, 0.6}};
    tf.opacityX = {-15, -5.5, -4.5, -3.5, -0.6, 0, 0.6, 2.4, 3, 3.6, 25};
    tf.opacity = {0, 0, 0.9, 0, 0, 0.45, 0, 0, 0.12, 0, 0};
    return tf;
}

// The model for q (built once per q) and 4096 random index-space points.
const ModelVolume& modelFor(int q) {
    static std::vector<ModelVolume> models(17);
    if (models[q].voxelCount() == 0) models[q] = benchModel(q);
    return models[q];
}
std::vector<float> benchPoints() {
    std::vector<float> pts(3 * 4096);
    CounterRng rng(5, 0, 0);
    for (auto& p : pts) p = static_cast<float>(rng.uniform() * 31.0);
    return pts;
}

// The exact (double) body, one sample at a time.
void BM_ClassifyExact(benchmark::State& state) {
    const ModelKind kind = allModelKinds()[static_cast<std::size_t>(state.range(0))];
    const int q = static_cast<int>(state.range(1));
    const ModelVolume& m = modelFor(q);
    const TransferFunction1D tf = benchTf();
    const std::vector<float> pts = benchPoints();
    state.SetLabel(std::string(modelName(kind)) + " q=" + std::to_string(q));
    withKernel(m, kind, tf, [&](const auto& k) {
        for (auto _ : state) {
            double acc = 0.0;
            for (std::size_t i = 0; i < pts.size(); i += 3) {
                double v[4];
                classifyAt<double>(k, pts[i], pts[i + 1], pts[i + 2], v);
                acc += v[3];
            }
            benchmark::DoNotOptimize(acc);
        }
    });
    state.SetItemsProcessed(state.iterations() * 4096);
}

// The lane body, lanes::kWidth samples per call (all lanes live).
void BM_ClassifyLanes(benchmark::State& state) {
    using lanes::Vf;
    const ModelKind kind = allModelKinds()[static_cast<std::size_t>(state.range(0))];
    const int q = static_cast<int>(state.range(1));
    const ModelVolume& m = modelFor(q);
    const TransferFunction1D tf = benchTf();
    const std::vector<float> pts = benchPoints();
    // Structure of arrays: the points in batches of lanes::kWidth.
    std::vector<float> soa(pts.size());
    for (std::size_t i = 0; i < 4096; ++i)
        for (std::size_t a = 0; a < 3; ++a) soa[a * 4096 + i] = pts[3 * i + a];
    state.SetLabel(std::string(modelName(kind)) + " q=" + std::to_string(q));
    withKernel(m, kind, tf, [&](const auto& k) {
        for (auto _ : state) {
            Vf acc{};
            for (std::size_t i = 0; i < 4096; i += lanes::kWidth) {
                const Cell<Vf> cell =
                    cellAt<Vf>(k.geometry, lanes::load(&soa[i]), lanes::load(&soa[4096 + i]),
                               lanes::load(&soa[2 * 4096 + i]));
                Vf v[4];
                k.finish(k.template load<Vf>(cell, lanes::allTrue<Vf>()), v);
                acc += v[3];
            }
            benchmark::DoNotOptimize(acc);
        }
    });
    state.SetItemsProcessed(state.iterations() * 4096);
}

void args(benchmark::internal::Benchmark* b) {
    for (std::size_t i = 0; i < allModelKinds().size(); ++i) {
        if (rendersRealizations(allModelKinds()[i])) continue;  // gmm-mc: no per-sample kernel
        for (int q : {2, 4, 8, 16}) {
            const ModelKind k = allModelKinds()[i];
            const bool usesQ = needsQuantiles(k);
            if (!usesQ && q != 8) continue;  // q only matters to the quantile models
            // The quartile views need q divisible by 4 (a population inside [0, 1]).
            const auto pop = modelRow(k).population;
            if (pop.second > pop.first && pop.second - pop.first < 1.0 && q % 4 != 0) continue;
            b->Args({static_cast<long>(i), q});
        }
    }
}
BENCHMARK(BM_ClassifyExact)->Apply(args);
BENCHMARK(BM_ClassifyLanes)->Apply(args);

}  // namespace

BENCHMARK_MAIN();
