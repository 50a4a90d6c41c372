#include "udvr/render/render.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <type_traits>
#include <vector>

#include "udvr/classify/model_families.h"
#include "udvr/render/ray_march.h"
#include "udvr/util/check.h"
#include "udvr/util/parallel.h"
#include "udvr/util/progress.h"
#include "udvr/util/random.h"

namespace udvr {
namespace {

// The world box rays sample: the full-resolution bounds the model carries (SPEC §5), or its
// own grid's box when a hand-made model left them unset.
std::array<double, 6> renderBounds(const ModelView& model) {
    const auto& b = model.bounds;
    bool unset = true;
    for (double v : b) unset = unset && v == 0.0;
    if (unset) return model.grid.bounds();
    for (int a = 0; a < 3; ++a)
        if (!(b[2 * a] <= b[2 * a + 1]) || !std::isfinite(b[2 * a]) || !std::isfinite(b[2 * a + 1]))
            UDVR_FAIL("model bounds must be finite with min <= max on every axis");
    return b;
}

detail::MarchParams makeParams(const ModelView& model, const RenderSettings& s) {
    if (s.width < 1 || s.height < 1 || s.width > 16384 || s.height > 16384)
        UDVR_FAIL("image size must be in [1, 16384] per side, got " << s.width << "x" << s.height);
    for (int a = 0; a < 3; ++a) {
        if (model.grid.dims[a] < 1) UDVR_FAIL("model grid has an empty axis");
        if (!(model.grid.spacing[a] > 0.0) || !std::isfinite(model.grid.spacing[a]))
            UDVR_FAIL("model grid spacing must be positive, got " << model.grid.spacing[a]);
    }
    const double fullRes =
        model.fullResMinSpacing > 0.0 ? model.fullResMinSpacing : model.grid.minSpacing();
    detail::MarchParams p;
    p.frame = makeCameraFrame(s.camera, s.width, s.height);
    p.bounds = renderBounds(model);
    p.grid = model.grid;
    p.step = s.step > 0.0 ? s.step : 0.5 * fullRes;  // world units
    if (s.step < 0.0 || !std::isfinite(s.step)) UDVR_FAIL("--step must be > 0, got " << s.step);
    const double unit = s.unitDistance > 0.0 ? s.unitDistance : fullRes;  // world units
    if (s.unitDistance < 0.0 || !std::isfinite(s.unitDistance))
        UDVR_FAIL("--unit-distance must be > 0, got " << s.unitDistance);
    // A frame of more than ~1e9 samples per ray is a mistake (a step far too small).
    const double diag =
        std::sqrt(std::pow(p.bounds[1] - p.bounds[0], 2) + std::pow(p.bounds[3] - p.bounds[2], 2) +
                  std::pow(p.bounds[5] - p.bounds[4], 2));
    if (diag / p.step > 1e9) UDVR_FAIL("--step " << p.step << " is too small for the volume");
    p.opacityExponent = static_cast<float>(p.step / unit);
    if (!(s.earlyExit > 0.0 && s.earlyExit <= 1.0))
        UDVR_FAIL("--early-exit must be in (0, 1], got " << s.earlyExit);
    p.earlyExit = static_cast<float>(s.earlyExit);
    for (float c : s.background)
        if (!(c >= 0.f && c <= 1.f)) UDVR_FAIL("--background values must lie in [0, 1]");
    p.background = s.background;
    p.skipEmpty = s.skipEmpty;
    p.jitter = s.jitterSeed.has_value();
    p.jitterSeed = s.jitterSeed.value_or(0);
    if (s.piece) {
        p.clip = true;
        p.clipBox = s.piece->box;
        for (int a = 0; a < 3; ++a)
            if (!(p.clipBox[2 * a] <= p.clipBox[2 * a + 1]) || !std::isfinite(p.clipBox[2 * a]) ||
                !std::isfinite(p.clipBox[2 * a + 1]))
                UDVR_FAIL("the piece's box must be finite with min <= max on every axis");
        for (int a = 0; a < 3; ++a)
            if (s.piece->offset[a] < 0 ||
                s.piece->offset[a] + model.grid.dims[a] > s.piece->wholeDims[a])
                UDVR_FAIL("the piece's grid (offset "
                          << s.piece->offset[a] << ", " << model.grid.dims[a]
                          << " points) must lie in the whole grid (" << s.piece->wholeDims[a]
                          << " points)");
    }
    p.cancel = s.cancel;
    return p;
}

ImageRgba blankImage(int width, int height) {
    ImageRgba img;
    img.width = width;
    img.height = height;
    img.rgba.assign(static_cast<std::size_t>(width) * height * 4, 0.f);
    return img;
}

// What the cached skipping tables were built from: the model's arrays (by address: a view made
// for each call, or borrowed arrays, has no identity of its own), the kind and whether its 1D or
// 2D kernel (their voxel supports), and the TF's non-zero-opacity value ranges.
struct CacheKey {
    std::vector<const void*> arrays;
    std::size_t voxels = 0;
    std::array<int, 3> dims{};
    ModelKind kind = ModelKind::Mean;
    bool uniformMinMax = false;
    bool twoD = false;
    std::vector<const void*> secondArrays;  // bivariate fields: the second model's
    std::vector<std::pair<double, double>> ranges;

    bool operator==(const CacheKey& o) const = default;
};

std::vector<const void*> arraysOf(const ModelView& m) {
    return {m.mean.data(),      m.stddev.data(), m.min.data(), m.max.data(),
            m.quantiles.data(), m.iqr.data(),    m.gmm.data(), m.members.data()};
}

CacheKey makeKey(const ModelView& m, ModelKind kind, bool twoD,
                 const std::vector<std::pair<double, double>>& ranges, bool uniformMinMax,
                 const ModelView* second = nullptr) {
    CacheKey k;
    k.arrays = arraysOf(m);
    if (second) k.secondArrays = arraysOf(*second);
    k.voxels = m.voxelCount();
    k.dims = m.grid.dims;
    k.kind = kind;
    k.uniformMinMax = uniformMinMax;
    k.twoD = twoD;
    k.ranges = ranges;
    return k;
}

}  // namespace

struct RenderCache::Impl {
    bool valid = false;
    CacheKey key;
    detail::SkipTable table;
    GradientCache gradients;  // 2D TFs: the grid gradients of the model's arrays
};

RenderCache::RenderCache() : impl_(std::make_unique<Impl>()) {}
RenderCache::~RenderCache() = default;
void RenderCache::clear() {
    impl_->valid = false;
    impl_->gradients.clear();
}

namespace {

// Build (or reuse from `cache` under `key`) the skipping tables and march the frame.
template <class Kernel>
void renderKernel(const Kernel& kernel, const detail::MarchParams& p,
                  const std::vector<std::pair<double, double>>& ranges, ImageRgba& image,
                  detail::MarchCounters& counters, RenderCache::Impl* cache = nullptr,
                  const CacheKey* key = nullptr) {
    if (!kernel.geometry.fitsInt32)
        UDVR_FAIL("the model grid has " << p.grid.pointCount()
                                        << " points; the renderer handles at most 2^31 - 1");
    if (!p.skipEmpty) {
        detail::marchFrame(kernel, detail::SkipTable{}, nullptr, p, image, counters);
        return;
    }
    const auto march = [&](const detail::SkipTable& table) {
        detail::marchFrame(kernel, table, table.cellEmptyBits.data(), p, image, counters);
    };
    if (cache && key) {
        if (!cache->valid || !(cache->key == *key)) {
            cache->valid = false;
            cache->table = detail::buildSkipTable(kernel, p.grid, ranges);
            cache->key = *key;
            cache->valid = true;
        }
        march(cache->table);
        return;
    }
    march(detail::buildSkipTable(kernel, p.grid, ranges));
}

// Draw one gmm-mc realization: every voxel independently from its own mixture (SPEC §3),
// keyed by (seed, realization, voxel) so the field does not depend on the thread count.
// A piece (RenderSettings::piece) keys its voxels by their index in the whole grid.
void drawRealization(const ModelView& model, std::uint64_t seed, std::uint64_t realization,
                     const std::optional<RenderPiece>& piece, std::vector<float>& out) {
    const int k = model.gmmComponents;
    const std::size_t n = model.voxelCount();
    const auto& dims = model.grid.dims;
    out.resize(n);
    parallelForChunks(n, 4096, [&](std::size_t begin, std::size_t end) {
        for (std::size_t v = begin; v < end; ++v) {
            const float* g = model.gmmAt(v);  // π_1..π_K, μ_1..μ_K, σ_1..σ_K
            std::size_t key = v;
            if (piece) {
                const std::size_t x = static_cast<std::size_t>(dims[0]),
                                  y = static_cast<std::size_t>(dims[1]);
                const std::size_t i = v % x + static_cast<std::size_t>(piece->offset[0]);
                const std::size_t j = v / x % y + static_cast<std::size_t>(piece->offset[1]);
                const std::size_t kk = v / (x * y) + static_cast<std::size_t>(piece->offset[2]);
                key = (kk * static_cast<std::size_t>(piece->wholeDims[1]) + j) *
                          static_cast<std::size_t>(piece->wholeDims[0]) +
                      i;
            }
            CounterRng rng(seed, realization, key);
            double total = 0.0;
            for (int c = 0; c < k; ++c) total += std::max(0.0, static_cast<double>(g[c]));
            const double u = rng.uniform() * total;
            int pick = k - 1;
            double cum = 0.0;
            for (int c = 0; c < k; ++c) {
                cum += std::max(0.0, static_cast<double>(g[c]));
                if (u < cum) {
                    pick = c;
                    break;
                }
            }
            const double mu = g[k + pick],
                         sigma = std::max(0.0, static_cast<double>(g[2 * k + pick]));
            out[v] = static_cast<float>(mu + sigma * rng.normal());
        }
    });
}

// One frame: its parameters, a blank image and counters; march(p, image, counters) fills it.
template <class March>
ImageRgba timedFrame(const ModelView& model, const RenderSettings& settings, RenderStats* stats,
                     const March& march) {
    const auto start = std::chrono::steady_clock::now();
    const detail::MarchParams p = makeParams(model, settings);
    ImageRgba image = blankImage(settings.width, settings.height);
    detail::MarchCounters counters;
    march(p, image, counters);
    if (settings.cancel && settings.cancel->load()) throw RenderCancelled();
    if (stats) {
        stats->milliseconds =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                .count();
        stats->samples = counters.samples.load();
        stats->skippedSamples = counters.skipped.load();
    }
    return image;
}

}  // namespace

namespace {

// One frame's classification context: the TF's value ranges with α > 0, the skip-table cache
// and its key, the classify options of the settings.
struct FrameContext {
    const detail::MarchParams& p;
    ImageRgba& image;
    detail::MarchCounters& counters;
    std::vector<std::pair<double, double>> ranges;
    RenderCache::Impl* cacheImpl;
    CacheKey key;
    ClassifyOptions options;

    template <class Kernel>
    void render(const Kernel& kernel) const {
        renderKernel(kernel, p, ranges, image, counters, cacheImpl, &key);
    }
};

// A timed frame of `model` (second: a bivariate field's y) under a 1D or 2D TF: body(context)
// makes the kernels and renders.
template <class Tf, class Body>
ImageRgba renderFrame(const ModelView& model, const ModelView* second, ModelKind kind, const Tf& tf,
                      const RenderSettings& settings, RenderStats* stats, RenderCache* cache,
                      const Body& body) {
    constexpr bool twoD = std::is_same_v<Tf, TransferFunction2D>;
    return timedFrame(
        model, settings, stats,
        [&](const detail::MarchParams& p, ImageRgba& image, detail::MarchCounters& counters) {
            tf.validate();
            FrameContext c{p, image, counters, {}, cache ? &cache->impl() : nullptr, {}, {}};
            if constexpr (twoD)
                c.ranges = tf.nonZeroOpacityXRanges();
            else
                c.ranges = tf.nonZeroOpacityRanges();
            if (cache) c.key = makeKey(model, kind, twoD, c.ranges, settings.uniformMinMax, second);
            c.options.uniformMinMax = settings.uniformMinMax;
            body(c);
        });
}

}  // namespace

ImageRgba renderVolume(const ModelView& model, ModelKind kind, const TransferFunction1D& tf,
                       const RenderSettings& settings, RenderStats* stats, RenderCache* cache) {
    return renderFrame(model, nullptr, kind, tf, settings, stats, cache, [&](FrameContext& c) {
        if (!modelFamily(kind).realizations) {
            withKernel(model, kind, tf, c.options, [&](const auto& kernel) { c.render(kernel); });
            return;
        }
        checkModelHasArrays(model, kind);
        if (settings.realizations < 1)
            UDVR_FAIL("--realizations must be >= 1, got " << settings.realizations);
        const TfPiecesStorage pieces(tf);
        std::vector<double> sum(c.image.rgba.size(), 0.0);
        std::vector<float> values;
        ImageRgba frame = blankImage(settings.width, settings.height);
        ProgressBar bar("gmm-mc", static_cast<std::size_t>(settings.realizations));
        for (int r = 0; r < settings.realizations; ++r) {
            if (c.p.cancel && c.p.cancel->load()) return;  // timedFrame throws RenderCancelled
            drawRealization(model, settings.seed, static_cast<std::uint64_t>(r), settings.piece,
                            values);
            renderKernel(MeanKernel(model.grid, values.data(), pieces), c.p, c.ranges, frame,
                         c.counters);
            for (std::size_t i = 0; i < sum.size(); ++i) sum[i] += frame.rgba[i];
            bar.advance();
        }
        bar.finish();
        // Screen-space average of the realizations' images (Liu et al. 2012).
        const double inv = 1.0 / settings.realizations;
        for (std::size_t i = 0; i < sum.size(); ++i)
            c.image.rgba[i] = static_cast<float>(sum[i] * inv);
    });
}

ImageRgba renderVolume(const ModelView& model, ModelKind kind, const TransferFunction2D& tf,
                       const RenderSettings& settings, RenderStats* stats, RenderCache* cache) {
    return renderFrame(model, nullptr, kind, tf, settings, stats, cache, [&](FrameContext& c) {
        withKernel2D(
            model, kind, tf, c.options, [&](const auto& kernel) { c.render(kernel); },
            c.cacheImpl ? &c.cacheImpl->gradients : nullptr);
    });
}

ImageRgba renderBivariate(const ModelView& first, const ModelView& second, ModelKind kind,
                          const TransferFunction2D& tf, const RenderSettings& settings,
                          RenderStats* stats, RenderCache* cache) {
    return renderFrame(first, &second, kind, tf, settings, stats, cache, [&](FrameContext& c) {
        withKernelBivariate(first, second, kind, tf, c.options,
                            [&](const auto& kernel) { c.render(kernel); });
    });
}

namespace {

// The first sample of pixel (px, py)'s ray whose E[α] passes the pick thresholds (render.h).
template <class Kernel>
std::optional<std::array<double, 3>> pickOnRay(const Kernel& kernel, const detail::MarchParams& p,
                                               int px, int py) {
    if (px < 0 || py < 0 || px >= p.frame.width || py >= p.frame.height)
        UDVR_FAIL("pixel (" << px << ", " << py << ") is outside the " << p.frame.width << "x"
                            << p.frame.height << " image");
    const detail::RaySamples r = detail::raySamples(p, px, py);
    std::vector<double> alpha(static_cast<std::size_t>(std::max<std::int64_t>(r.n, 0)));
    double largest = 0.0;
    const auto at = [&](std::int64_t s, int ax) {  // index space, as the ray loop's a + s·b
        return static_cast<double>(r.a[ax]) + static_cast<double>(s) * r.b[ax];
    };
    for (std::int64_t s = 0; s < r.n; ++s) {
        double v[4];
        classifyAt<double>(kernel, static_cast<float>(at(s, 0)), static_cast<float>(at(s, 1)),
                           static_cast<float>(at(s, 2)), v);
        alpha[static_cast<std::size_t>(s)] = v[3];
        largest = std::max(largest, v[3]);
    }
    const double threshold = std::max(kPickMinOpacity, kPickOpacityFraction * largest);
    for (std::int64_t s = 0; s < r.n; ++s) {
        if (!(alpha[static_cast<std::size_t>(s)] >= threshold)) continue;
        std::array<double, 3> point;
        for (int ax = 0; ax < 3; ++ax)
            point[ax] = std::clamp(at(s, ax), 0.0, static_cast<double>(p.grid.dims[ax] - 1));
        return point;
    }
    return std::nullopt;
}

// Pick on the frame of `settings` over `model` with the kernel withKernel(options, f) makes.
template <class WithKernel>
std::optional<std::array<double, 3>> pick(const ModelView& model, const RenderSettings& settings,
                                          int px, int py, const WithKernel& withKernel) {
    const detail::MarchParams p = makeParams(model, settings);
    ClassifyOptions options;
    options.uniformMinMax = settings.uniformMinMax;
    std::optional<std::array<double, 3>> hit;
    withKernel(options, [&](const auto& kernel) { hit = pickOnRay(kernel, p, px, py); });
    return hit;
}

}  // namespace

std::optional<std::array<double, 3>> firstVisibleSample(const ModelView& model, ModelKind kind,
                                                        const TransferFunction1D& tf,
                                                        const RenderSettings& settings, int px,
                                                        int py) {
    tf.validate();
    const ModelKind pickKind = kernelStandIn(kind);
    return pick(model, settings, px, py, [&](const ClassifyOptions& options, const auto& f) {
        withKernel(model, pickKind, tf, options, f);
    });
}

std::optional<std::array<double, 3>> firstVisibleSample(const ModelView& model, ModelKind kind,
                                                        const TransferFunction2D& tf,
                                                        const RenderSettings& settings, int px,
                                                        int py) {
    tf.validate();
    return pick(model, settings, px, py, [&](const ClassifyOptions& options, const auto& f) {
        withKernel2D(model, kind, tf, options, f);
    });
}

std::optional<std::array<double, 3>> firstVisibleSampleBivariate(
    const ModelView& first, const ModelView& second, ModelKind kind, const TransferFunction2D& tf,
    const RenderSettings& settings, int px, int py) {
    tf.validate();
    return pick(first, settings, px, py, [&](const ClassifyOptions& options, const auto& f) {
        withKernelBivariate(first, second, kind, tf, options, f);
    });
}

}  // namespace udvr
