// Benchmarks of `udvr build`'s statistics (stats/build_model): the tangle perturbed with the
// paper's bimodal noise, built to q quantiles + a K-component GMM. Throughput is reported as
// voxels per second. Targets (issue 3): 64³ × 50 members, q=8, GMM(4) under 2 s on 2 cores;
// 500×500×50 × 20 members (BM_BuildRedSeaSize, run it with --benchmark_filter) under 60 s, and
// since issue 15 at most 30 s (docs/building.md, "Timings").
#include <benchmark/benchmark.h>

#include <map>
#include <tuple>

#include "udvr/data/noise.h"
#include "udvr/data/synthetic.h"
#include "udvr/stats/build_model.h"

namespace {

// Ensembles are cached: generating one costs more than some of the builds measured.
const udvr::Ensemble& ensemble(int nx, int ny, int nz, int members) {
    static std::map<std::tuple<int, int, int, int>, udvr::Ensemble> cache;
    auto key = std::make_tuple(nx, ny, nz, members);
    auto it = cache.find(key);
    if (it == cache.end()) {
        udvr::NoiseParams p;
        it = cache.emplace(key, udvr::perturbField(udvr::makeTangle(nx, ny, nz), members, p)).first;
    }
    return it->second;
}

void runBuild(benchmark::State& state, const udvr::Ensemble& e, const udvr::BuildOptions& opt) {
    udvr::BuildReport rep;
    for (auto _ : state) {
        udvr::ModelVolume m = udvr::buildModel(e, opt, &rep);
        benchmark::DoNotOptimize(m.mean.data());
    }
    state.counters["voxels/s"] = benchmark::Counter(
        static_cast<double>(e.grid.pointCount()) * static_cast<double>(state.iterations()),
        benchmark::Counter::kIsRate);
    state.counters["em_iter"] = rep.meanGmmIterations;
}

// The 64³ × 50 target; args: density (0 empirical, 1 kde), q, K.
void BM_Build64(benchmark::State& state) {
    udvr::BuildOptions opt;
    opt.density = state.range(0) ? udvr::DensityEstimate::Kde : udvr::DensityEstimate::Empirical;
    opt.quantiles = static_cast<int>(state.range(1));
    opt.gmmComponents = static_cast<int>(state.range(2));
    runBuild(state, ensemble(64, 64, 64, 50), opt);
}
BENCHMARK(BM_Build64)
    ->ArgNames({"kde", "q", "K"})
    ->Args({0, 8, 4})
    ->Args({1, 8, 4})
    ->Args({0, 8, 0})
    ->Args({1, 8, 0})
    ->Args({0, 0, 4})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Scaling with members (32³ grid); args: members, density, K.
void BM_BuildMembers(benchmark::State& state) {
    udvr::BuildOptions opt;
    opt.density = state.range(1) ? udvr::DensityEstimate::Kde : udvr::DensityEstimate::Empirical;
    opt.gmmComponents = static_cast<int>(state.range(2));
    runBuild(state, ensemble(32, 32, 32, static_cast<int>(state.range(0))), opt);
}
BENCHMARK(BM_BuildMembers)
    ->ArgNames({"members", "kde", "K"})
    ->ArgsProduct({{10, 20, 50, 100, 200}, {0, 1}, {0, 4}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Scaling with q (32³ × 50, no GMM); args: q, density.
void BM_BuildQuantiles(benchmark::State& state) {
    udvr::BuildOptions opt;
    opt.quantiles = static_cast<int>(state.range(0));
    opt.density = state.range(1) ? udvr::DensityEstimate::Kde : udvr::DensityEstimate::Empirical;
    opt.gmmComponents = 0;
    runBuild(state, ensemble(32, 32, 32, 50), opt);
}
BENCHMARK(BM_BuildQuantiles)
    ->ArgNames({"q", "kde"})
    ->ArgsProduct({{4, 8, 16, 32}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The Red Sea size: 500×500×50 × 20 members, q=8, GMM(4), empirical. ~1 GiB of input.
void BM_BuildRedSeaSize(benchmark::State& state) {
    udvr::BuildOptions opt;
    opt.density = state.range(0) ? udvr::DensityEstimate::Kde : udvr::DensityEstimate::Empirical;
    runBuild(state, ensemble(500, 500, 50, 20), opt);
}
BENCHMARK(BM_BuildRedSeaSize)
    ->ArgNames({"kde"})
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kSecond)
    ->UseRealTime()
    ->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
