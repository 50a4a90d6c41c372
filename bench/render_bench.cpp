// Frame rate of the CPU ray caster (render/) for every model at 512², on the 64³ tangle and a
// 256³ tangle, single- and multi-threaded. TF: the peer harness's three-band tangle TF
// (bench/peer/make_tangle.py); camera: azimuth 30, elevation 20, view angle 30; Δ = half the
// spacing; opacity unit distance 5/63 (the peer sweep's, so every size shows the same picture).
//
// Models other than `mean` are synthesised per voxel around the tangle value f with the shape
// of the paper's bimodal noise (80 % near f, 20 % outliers at f + 0.2·range): building real
// 256³ models from ensembles would take minutes, and the frame cost depends only on the arrays'
// layout, q, K and how much of the volume the TF makes visible.
//
//   render_bench --benchmark_filter='BM_Render/model:0/n:64'   (the mean field at 64³)
#include <benchmark/benchmark.h>

#include <array>
#include <map>
#include <memory>
#include <utility>

#include "udvr/classify/model_kind.h"
#include "udvr/classify/tf_presets.h"
#include "udvr/data/synthetic.h"
#include "udvr/render/render.h"
#include "udvr/stats/model_volume.h"
#include "udvr/util/parallel.h"

namespace {

using udvr::ModelKind;

// Every array of SPEC §7 (q = 8, K = 4) around the tangle value of each voxel.
udvr::ModelVolume syntheticModel(int n) {
    udvr::ModelVolume m = udvr::modelFromField(udvr::makeTangle(n, n, n));
    constexpr int q = 8, k = 4;
    // Offsets of the empirical quantiles of 80 % N(0, 0.84²) + 20 % N(8.4, 1.7²) (data units).
    constexpr std::array<float, q + 1> qo{-2.5f, -1.0f, -0.55f, -0.2f, 0.1f,
                                          0.45f, 0.9f,  7.0f,   10.5f};
    constexpr std::array<float, 3 * k> g{0.4f, 0.4f, 0.1f, 0.1f, -0.6f, 0.6f,
                                         7.5f, 9.3f, 0.6f, 0.6f, 1.0f,  1.0f};
    const std::size_t nv = m.voxelCount();
    m.quantileCount = q;
    m.quantiles.resize(nv * (q + 1));
    m.iqr.resize(nv * 2);
    m.gmmComponents = k;
    m.gmm.resize(nv * 3 * k);
    for (std::size_t v = 0; v < nv; ++v) {
        const float f = m.mean[v];
        for (int j = 0; j <= q; ++j) m.quantiles[v * (q + 1) + j] = f + qo[j];
        m.iqr[2 * v] = f + qo[2];
        m.iqr[2 * v + 1] = f + qo[6];
        for (int c = 0; c < 3 * k; ++c)
            m.gmm[v * 3 * k + c] = (c >= k && c < 2 * k) ? f + g[c] : g[c];
        m.stddev[v] = 3.4f;
        m.min[v] = f + qo[0];
        m.max[v] = f + qo[q];
        m.mean[v] = f + 1.6f;
    }
    m.samplesPerVoxel = 50;
    return m;
}

const udvr::ModelVolume& model(int n) {
    static std::map<int, std::unique_ptr<udvr::ModelVolume>> cache;
    auto& slot = cache[n];
    if (!slot) slot = std::make_unique<udvr::ModelVolume>(syntheticModel(n));
    return *slot;
}

// The ground truth (a plain field, model `mean`) and every model of SPEC §3; `uniform` is the
// exact box spline (seconds per frame), `uniform-fast` (last, model:10) its fast form.
constexpr std::array<std::pair<ModelKind, bool>, 11> kKinds{{{ModelKind::Mean, true},
                                                             {ModelKind::Mean, false},
                                                             {ModelKind::Uniform, false},
                                                             {ModelKind::Gaussian, false},
                                                             {ModelKind::GmmOrdered, false},
                                                             {ModelKind::GmmMc, false},
                                                             {ModelKind::QuantileRange, false},
                                                             {ModelKind::QuantileMean, false},
                                                             {ModelKind::QuantileMeanMass, false},
                                                             {ModelKind::Iqr, false},
                                                             {ModelKind::UniformFast, false}}};

void BM_Render(benchmark::State& state) {
    const auto [kind, truth] = kKinds[static_cast<std::size_t>(state.range(0))];
    const int n = static_cast<int>(state.range(1));
    const int threads = static_cast<int>(state.range(2));
    static std::map<int, std::unique_ptr<udvr::ModelVolume>> truths;
    auto& t = truths[n];
    if (truth && !t)
        t = std::make_unique<udvr::ModelVolume>(udvr::modelFromField(udvr::makeTangle(n, n, n)));
    const udvr::ModelVolume& m = truth ? *t : model(n);
    const udvr::TransferFunction1D tf = udvr::tangleTransferFunction();
    udvr::RenderSettings s;
    s.width = s.height = 512;
    s.camera = udvr::defaultCamera(m.bounds);  // SPEC §5's
    s.unitDistance = 5.0 / 63.0;
    s.realizations = 1;  // gmm-mc: the cost of one realization (a frame averages R of them)
    udvr::setThreadCount(threads);
    // As VTK's mapper, keep the skipping tables from the warm-up frame.
    udvr::RenderCache cache;
    udvr::renderVolume(m, kind, tf, s, nullptr, &cache);  // warm-up
    udvr::RenderStats st;
    for (auto _ : state) {
        udvr::ImageRgba img = udvr::renderVolume(m, kind, tf, s, &st, &cache);
        benchmark::DoNotOptimize(img.rgba.data());
    }
    udvr::setThreadCount(0);
    state.SetLabel(std::string(truth ? "field" : udvr::modelName(kind)));
    state.counters["fps"] =
        benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
    state.counters["Msamples"] = static_cast<double>(st.samples) * 1e-6;
}
BENCHMARK(BM_Render)
    ->ArgNames({"model", "n", "threads"})
    ->ArgsProduct({{0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10}, {64, 256}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(1.0);

}  // namespace

BENCHMARK_MAIN();
