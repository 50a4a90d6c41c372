#include "udvr/stats/gmm.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>

#include "udvr/util/check.h"
#include "udvr/util/random.h"

namespace udvr {
namespace {

// 8-lane float vectors (GCC/Clang vector extensions; AVX where the target has it). The EM pass
// below is written on them because GCC does not vectorise floating-point reductions by itself.
// Float suffices inside one pass: samples are taken relative to the voxel mean, the M-step sums
// relative to each component's current mean, and the log-likelihood is summed in double.
using V8f = float __attribute__((vector_size(32)));
using V8i = std::int32_t __attribute__((vector_size(32)));

V8f splat(float v) { return V8f{v, v, v, v, v, v, v, v}; }

// e^x for x ≤ 0, relative error < 3e−7 down to x = −87 (clamped there: e^−87 ≈ 2e−38 is nothing
// next to the row maximum's e^0 = 1). x = n·ln2 + r, |r| ≤ ln2/2, e^r by its degree-6 Taylor
// polynomial (error r⁷/7! < 1.2e−7), 2^n from the bits of the rounding shifter.
inline V8f expNonPositive(V8f x) {
    x = x < splat(-87.f) ? splat(-87.f) : x;
    const V8f shifter = splat(0x1.8p23f);            // adding it rounds to an integer
    const V8f t = x * splat(1.44269504f) + shifter;  // low mantissa bits: 2^22 + n
    const V8f n = t - shifter;
    const V8f r = (x - n * splat(0.693145752f)) - n * splat(1.42860677e-6f);  // ln2 = hi + lo
    V8f p = splat(1.f / 720.f);
    p = p * r + splat(1.f / 120.f);
    p = p * r + splat(1.f / 24.f);
    p = p * r + splat(1.f / 6.f);
    p = p * r + splat(0.5f);
    p = p * r + splat(1.f);
    p = p * r + splat(1.f);
    // (2^22 + n + 127) << 23 keeps the low 9 bits, n + 127 ∈ [1, 127]: the exponent of 2^n.
    const V8i bits = (std::bit_cast<V8i>(t) + 127) << 23;
    return p * std::bit_cast<V8f>(bits);
}

// log(s) for s ≥ 1 (finite): s = 2^e·f with f ∈ [√½, √2), log f = 2·atanh(t), t = (f−1)/(f+1),
// |t| ≤ 0.172, series to t⁹ (error < 1e−9, below float resolution).
inline V8f logAtLeastOne(V8f s) {
    const V8i bits = std::bit_cast<V8i>(s);
    const V8i expo = (bits >> 23) - 127;  // ≥ 0 for s ≥ 1
    const V8i mant = (bits & 0x007FFFFF) | 0x3F800000;
    V8f f = std::bit_cast<V8f>(mant);
    V8f e = std::bit_cast<V8f>(expo + 0x4B000000) - splat(0x1p23f);  // 2^23 + e as a float
    const auto big = f > splat(1.41421356f);
    f = big ? f * splat(0.5f) : f;
    e = big ? e + splat(1.f) : e;
    const V8f t = (f - splat(1.f)) / (f + splat(1.f));
    const V8f t2 = t * t;
    V8f p = splat(1.f / 9.f);
    p = p * t2 + splat(1.f / 7.f);
    p = p * t2 + splat(1.f / 5.f);
    p = p * t2 + splat(1.f / 3.f);
    p = p * t2 + splat(1.f);
    return e * splat(0.693147181f) + splat(2.f) * t * p;
}

using V8d = double __attribute__((vector_size(64)));

// Tree sums of the lanes (short dependency chains).
double sum8(V8f v) {
    return static_cast<double>(((v[0] + v[4]) + (v[1] + v[5])) + ((v[2] + v[6]) + (v[3] + v[7])));
}
double sum8(V8d v) { return ((v[0] + v[4]) + (v[1] + v[5])) + ((v[2] + v[6]) + (v[3] + v[7])); }

struct Component {
    double pi, mu, sigma;
};

}  // namespace

GmmFitInfo fitGmm(std::span<const float> sorted, const GmmOptions& options, std::uint64_t stream,
                  std::span<float> out, GmmWorkspace& ws) {
    const int K = options.components;
    const std::size_t n = sorted.size();
    UDVR_CHECK(K >= 1 && K <= kMaxGmmComponents);
    UDVR_CHECK(out.size() == static_cast<std::size_t>(3 * K));
    UDVR_CHECK(n >= static_cast<std::size_t>(K) && options.sigmaFloor > 0.0);
    const double floorSigma = options.sigmaFloor;
    const double invN = 1.0 / static_cast<double>(n);

    double sampleMean = 0.0;
    for (float v : sorted) sampleMean += v;
    sampleMean *= invN;

    std::array<Component, kMaxGmmComponents> comp{};
    GmmFitInfo info;
    int d = 1;  // components actually fitted

    if (sorted.front() == sorted.back()) {
        // Point mass: all weight on one component; every μ at the value.
        comp[0] = {1.0, static_cast<double>(sorted.front()), floorSigma};
    } else {
        ws.x.assign(sorted.begin(), sorted.end());
        const double* x = ws.x.data();
        ws.d2.resize(n);
        double* d2 = ws.d2.data();

        // k-means++ seeding (Arthur & Vassilvitskii 2007): each next centre is a sample drawn
        // with probability ∝ D², its squared distance to the nearest centre chosen so far.
        CounterRng rng(options.seed, stream, 0);
        std::array<double, kMaxGmmComponents> centre{};
        centre[0] =
            x[std::min(n - 1, static_cast<std::size_t>(rng.uniform() * static_cast<double>(n)))];
        for (std::size_t i = 0; i < n; ++i) d2[i] = (x[i] - centre[0]) * (x[i] - centre[0]);
        while (d < K) {
            double total = 0.0;
            for (std::size_t i = 0; i < n; ++i) total += d2[i];
            if (!(total > 0.0)) break;  // fewer distinct values than K
            const double target = rng.uniform() * total;
            std::size_t pick = n;
            double cum = 0.0;
            for (std::size_t i = 0; i < n; ++i) {
                cum += d2[i];
                if (d2[i] > 0.0) {
                    pick = i;
                    if (cum > target) break;
                }
            }
            const double c = x[pick];
            centre[static_cast<std::size_t>(d++)] = c;
            for (std::size_t i = 0; i < n; ++i) d2[i] = std::min(d2[i], (x[i] - c) * (x[i] - c));
        }
        std::sort(centre.begin(), centre.begin() + d);

        // Initial parameters from the hard assignment to the nearest centre; with sorted samples
        // and centres the clusters are runs split at the midpoints. Each run holds its centre.
        std::size_t begin = 0;
        for (int k = 0; k < d; ++k) {
            std::size_t end = n;
            if (k + 1 < d) {
                const double mid = 0.5 * (centre[k] + centre[k + 1]);
                end = begin;
                while (end < n && x[end] <= mid) ++end;
            }
            double s = 0.0;
            for (std::size_t i = begin; i < end; ++i) s += x[i];
            const double cnt = static_cast<double>(end - begin);
            const double mu = cnt > 0.0 ? s / cnt : centre[k];
            double ss = 0.0;
            for (std::size_t i = begin; i < end; ++i) ss += (x[i] - mu) * (x[i] - mu);
            comp[k] = {cnt * invN, mu, std::max(cnt > 0.0 ? std::sqrt(ss / cnt) : 0.0, floorSigma)};
            begin = end;
        }

        // EM (Dempster et al. 1977) on d components, one fused pass per iteration: the E-step's
        // responsibilities for the current parameters are folded straight into the M-step's
        // weighted sums, 8 samples per vector. Samples are padded to a multiple of 8 with weight
        // 0 and taken relative to the sample mean.
        const std::size_t blocks = (n + 7) / 8;
        ws.xPadded.resize(8 * blocks);
        ws.weight.resize(8 * blocks);
        for (std::size_t i = 0; i < 8 * blocks; ++i) {
            ws.xPadded[i] = static_cast<float>((i < n ? x[i] : x[n - 1]) - sampleMean);
            ws.weight[i] = i < n ? 1.f : 0.f;
        }
        std::array<Component, kMaxGmmComponents> next{};
        // Returns the mean log-likelihood per sample of `comp` (without −½·log(2π)) and writes
        // the M-step's parameters to `next`.
        auto pass = [&]() {
            std::array<V8f, kMaxGmmComponents> a, b, mu, nk, s1, s2, e, dx;
            for (int k = 0; k < d; ++k) {
                a[k] = splat(static_cast<float>(std::log(std::max(comp[k].pi, 1e-300)) -
                                                std::log(comp[k].sigma)));
                b[k] = splat(static_cast<float>(-0.5 / (comp[k].sigma * comp[k].sigma)));
                mu[k] = splat(static_cast<float>(comp[k].mu - sampleMean));
                nk[k] = s1[k] = s2[k] = splat(0.f);
            }
            V8d ll{};  // per-lane sums in double: the convergence test needs ~1e−7 accuracy
            for (std::size_t blk = 0; blk < blocks; ++blk) {
                V8f xv, w;
                __builtin_memcpy(&xv, ws.xPadded.data() + 8 * blk, sizeof(V8f));
                __builtin_memcpy(&w, ws.weight.data() + 8 * blk, sizeof(V8f));
                V8f m = splat(-3e38f);
                for (int k = 0; k < d; ++k) {
                    dx[k] = xv - mu[k];
                    e[k] = a[k] + b[k] * dx[k] * dx[k];  // log(π_k·N(x | μ_k, σ_k)) + ½·log(2π)
                    m = e[k] > m ? e[k] : m;
                }
                V8f sum = splat(0.f);
                for (int k = 0; k < d; ++k) {
                    e[k] = expNonPositive(e[k] - m);
                    sum += e[k];
                }
                ll += __builtin_convertvector(w * (m + logAtLeastOne(sum)), V8d);  // sum ∈ [1, d]
                const V8f inv = w / sum;
                for (int k = 0; k < d; ++k) {
                    const V8f r = e[k] * inv;
                    nk[k] += r;
                    s1[k] += r * dx[k];  // about the current μ_k: little cancellation in s2
                    s2[k] += r * dx[k] * dx[k];
                }
            }
            for (int k = 0; k < d; ++k) {
                const double nkS = sum8(nk[k]);
                if (!(nkS > 1e-6)) {  // a component that lost its samples keeps its mean
                    next[k] = {0.0, comp[k].mu, floorSigma};
                    continue;
                }
                const double shift = sum8(s1[k]) / nkS;
                const double var = sum8(s2[k]) / nkS - shift * shift;
                next[k] = {nkS * invN, sampleMean + static_cast<double>(mu[k][0]) + shift,
                           std::max(std::sqrt(std::max(var, 0.0)), floorSigma)};
            }
            return sum8(ll) * invN;
        };

        double prev = 0.0;
        for (;;) {
            const double ll = pass();
            info.meanLogLikelihood = ll - 0.91893853320467274178;  // −½·log(2π)
            if (info.iterations > 0 && std::fabs(ll - prev) < options.tolerance) break;
            if (info.iterations >= options.maxIterations) {
                info.converged = false;
                break;
            }
            std::copy(next.begin(), next.begin() + d, comp.begin());
            ++info.iterations;
            prev = ll;
        }
    }

    // Spare components (fewer distinct values than K): zero weight at the sample mean.
    for (int k = d; k < K; ++k) comp[k] = {0.0, sampleMean, floorSigma};
    std::stable_sort(comp.begin(), comp.begin() + K,
                     [](const Component& a, const Component& b) { return a.mu < b.mu; });
    double piSum = 0.0;
    for (int k = 0; k < K; ++k) piSum += comp[k].pi;
    info.distinctComponents = 0;
    for (int k = 0; k < K; ++k) {
        if (comp[k].pi > 0.0) ++info.distinctComponents;
        out[k] = static_cast<float>(comp[k].pi / piSum);
        out[K + k] = static_cast<float>(comp[k].mu);
        out[2 * K + k] = static_cast<float>(comp[k].sigma);
    }
    return info;
}

}  // namespace udvr
