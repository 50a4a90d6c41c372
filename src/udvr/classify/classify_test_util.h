#pragma once
// Test helpers for classify/reconstruct tests: random transfer functions, random per-voxel
// distributions and in-memory model volumes (no files). Test-only.
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "udvr/classify/transfer_function.h"
#include "udvr/classify/transfer_function_2d.h"
#include "udvr/stats/model_volume.h"
#include "udvr/util/random.h"

namespace udvr::testing {

// A grid of `dims` with a random origin and spacing.
inline Grid3 randomGrid(CounterRng& rng, std::array<int, 3> dims) {
    Grid3 g;
    g.dims = dims;
    for (int a = 0; a < 3; ++a) {
        g.origin[a] = 4.0 * rng.uniform() - 2.0;
        g.spacing[a] = 0.3 + 1.5 * rng.uniform();
    }
    return g;
}

// A random raster TF2 of w×h points over [x0, x1] × [y0, y1], some α exactly 0.
inline TransferFunction2D randomTf2(CounterRng& rng, int w, int h, double x0, double x1, double y0,
                                    double y1) {
    TransferFunction2D t;
    t.width = w;
    t.height = h;
    t.x0 = x0;
    t.x1 = x1;
    t.y0 = y0;
    t.y1 = y1;
    for (int k = 0; k < w * h; ++k) {
        for (int ch = 0; ch < 3; ++ch) t.rgba.push_back(static_cast<float>(rng.uniform()));
        t.rgba.push_back(rng.uniform() < 0.25 ? 0.f : static_cast<float>(rng.uniform()));
    }
    t.validate();
    return t;
}

/// A random TF over [lo, hi]: 2–9 control points per function, some steps (repeated x), some
/// zero opacity; values in [0,1].
inline TransferFunction1D randomTf(CounterRng& rng, double lo, double hi) {
    TransferFunction1D tf;
    auto makeXs = [&](int n) {
        std::vector<double> xs;
        for (int i = 0; i < n; ++i) xs.push_back(lo + (hi - lo) * rng.uniform());
        std::sort(xs.begin(), xs.end());
        for (std::size_t i = 1; i < xs.size(); ++i)
            if (rng.uniform() < 0.25) xs[i] = xs[i - 1];  // a step
        return xs;
    };
    tf.colorX = makeXs(2 + static_cast<int>(rng.uniform() * 8));
    for (std::size_t i = 0; i < tf.colorX.size(); ++i)
        tf.color.push_back({rng.uniform(), rng.uniform(), rng.uniform()});
    tf.opacityX = makeXs(2 + static_cast<int>(rng.uniform() * 8));
    for (std::size_t i = 0; i < tf.opacityX.size(); ++i)
        tf.opacity.push_back(rng.uniform() < 0.3 ? 0.0 : rng.uniform());
    return tf;
}

/// The TF with every control point's x rounded to float, so that the float TF pieces have the
/// double pieces' breakpoints (steps sit at the same x in both views).
inline TransferFunction1D withFloatBreaks(TransferFunction1D tf) {
    for (double& x : tf.colorX) x = static_cast<float>(x);
    for (double& x : tf.opacityX) x = static_cast<float>(x);
    return tf;
}

/// Samples of one voxel: kind 0 normal, 1 skewed (lognormal), 2 bimodal, 3 tied (rounded),
/// 4 constant.
inline std::vector<double> randomSamples(CounterRng& rng, int kind, int n, double center,
                                         double scale) {
    std::vector<double> s(static_cast<std::size_t>(n));
    for (auto& v : s) {
        switch (kind) {
            case 0:
                v = center + scale * rng.normal();
                break;
            case 1:
                v = center + scale * (std::exp(0.8 * rng.normal()) - 1.0);
                break;
            case 2:
                v = center + scale * (rng.uniform() < 0.3 ? -1.5 : 1.0) +
                    0.2 * scale * rng.normal();
                break;
            case 3:
                v = center + scale * std::round(2.0 * rng.normal()) * 0.5;
                break;
            default:
                v = center;
                break;
        }
    }
    return s;
}

/// numpy's default (linear) sample quantile at p of sorted samples.
inline double sampleQuantile(const std::vector<double>& sorted, double p) {
    const double pos = p * static_cast<double>(sorted.size() - 1);
    const std::size_t i = static_cast<std::size_t>(pos);
    if (i + 1 >= sorted.size()) return sorted.back();
    const double t = pos - static_cast<double>(i);
    return sorted[i] + t * (sorted[i + 1] - sorted[i]);
}

/// A model over `dims` from random samples per voxel: mean, stddev, min, max, q quantiles, iqr,
/// a sorted K-component mixture (random parameters) and the samples as members (in draw order).
/// Distribution kinds cycle over voxels.
inline ModelVolume randomModel(CounterRng& rng, std::array<int, 3> dims, int q, int gmmK = 3,
                               int samples = 40) {
    ModelVolume m;
    m.grid.dims = dims;
    const std::size_t n = m.voxelCount();
    m.quantileCount = q;
    m.gmmComponents = gmmK;
    m.memberCount = samples;
    for (std::size_t v = 0; v < n; ++v) {
        const int kind = static_cast<int>(rng.uniform() * 5);
        auto s = randomSamples(rng, kind, samples, 2.0 * rng.normal(), 0.2 + rng.uniform());
        for (double x : s) m.members.push_back(static_cast<float>(x));
        std::sort(s.begin(), s.end());
        double mean = 0, var = 0;
        for (double x : s) mean += x;
        mean /= static_cast<double>(s.size());
        for (double x : s) var += (x - mean) * (x - mean);
        var /= static_cast<double>(s.size() - 1);
        m.mean.push_back(static_cast<float>(mean));
        m.stddev.push_back(static_cast<float>(std::sqrt(var)));
        m.min.push_back(static_cast<float>(s.front()));
        m.max.push_back(static_cast<float>(s.back()));
        for (int j = 0; j <= q; ++j)
            m.quantiles.push_back(static_cast<float>(sampleQuantile(s, double(j) / q)));
        m.iqr.push_back(static_cast<float>(sampleQuantile(s, 0.25)));
        m.iqr.push_back(static_cast<float>(sampleQuantile(s, 0.75)));
        std::vector<double> pi, mu, sg;
        for (int k = 0; k < gmmK; ++k) {
            pi.push_back(rng.uniform() + 0.05);
            mu.push_back(mean + 2.0 * rng.normal());
            sg.push_back(k == 0 ? 0.0 : 0.05 + rng.uniform());  // one σ = 0 component
        }
        std::sort(mu.begin(), mu.end());
        double ps = 0;
        for (double p : pi) ps += p;
        for (double p : pi) m.gmm.push_back(static_cast<float>(p / ps));
        for (double x : mu) m.gmm.push_back(static_cast<float>(x));
        for (double x : sg) m.gmm.push_back(static_cast<float>(x));
    }
    return m;
}

/// The 8 corners and trilinear weights of index-space point (x, y, z), written out here (SPEC
/// §1, §3) independently of reconstruct/cell.h: clamped into the grid, the last plane in the cell
/// below it with fraction 1, a 1-point axis has fraction 0.
struct RefCell {
    std::size_t corner[8];
    double weight[8];
};
inline RefCell refCell(const std::array<int, 3>& dims, float x, float y, float z) {
    const float p[3] = {x, y, z};
    int base[3];
    double f[3];
    for (int a = 0; a < 3; ++a) {
        const double v = std::clamp(static_cast<double>(p[a]), 0.0, dims[a] - 1.0);
        base[a] = dims[a] == 1 ? 0 : std::min(static_cast<int>(std::floor(v)), dims[a] - 2);
        f[a] = v - base[a];
    }
    RefCell c;
    for (int k = 0; k < 8; ++k) {
        std::size_t idx[3];
        c.weight[k] = 1.0;
        for (int a = 0; a < 3; ++a) {
            const bool up = (k >> a) & 1;
            idx[a] = static_cast<std::size_t>(base[a] + (up && dims[a] > 1 ? 1 : 0));
            c.weight[k] *= up ? f[a] : 1.0 - f[a];
        }
        c.corner[k] = idx[0] + static_cast<std::size_t>(dims[0]) *
                                   (idx[1] + static_cast<std::size_t>(dims[1]) * idx[2]);
    }
    return c;
}

/// Monte Carlo mean and standard error per channel of TF(X) for draws X = draw().
template <class Draw>
void monteCarlo(const TransferFunction1D& tf, int n, Draw draw, double mean[4], double se[4]) {
    double s[4] = {0, 0, 0, 0}, s2[4] = {0, 0, 0, 0};
    for (int i = 0; i < n; ++i) {
        const Rgba c = tf.classify(draw());
        const double v[4] = {c.r, c.g, c.b, c.a};
        for (int ch = 0; ch < 4; ++ch) {
            s[ch] += v[ch];
            s2[ch] += v[ch] * v[ch];
        }
    }
    for (int ch = 0; ch < 4; ++ch) {
        mean[ch] = s[ch] / n;
        const double var = std::max(0.0, s2[ch] / n - mean[ch] * mean[ch]);
        se[ch] = std::sqrt(var / n);
    }
}

}  // namespace udvr::testing
