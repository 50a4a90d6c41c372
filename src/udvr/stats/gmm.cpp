#include "udvr/stats/gmm.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "udvr/util/check.h"
#include "udvr/util/fast_math.h"
#include "udvr/util/lanes.h"
#include "udvr/util/random.h"

namespace udvr {
namespace {

// 16 voxels per vector: two AVX2 registers (or one AVX-512 register) per operation, so the long
// dependency chain of one sample (max → exp → sum → division → sums) overlaps with another's.
constexpr int kLanes = 16;
using VF = lanes::Vec<float, kLanes>;
using VI = lanes::Vec<std::int32_t, kLanes>;
using VD = lanes::Vec<double, kLanes>;
using VL = lanes::Vec<std::int64_t, kLanes>;
using lanes::less;  // a < b and mask ? a : b, a register at a time
using lanes::selectBits;
using lanes::splat;
constexpr double kHalfLog2Pi = 0.91893853320467274178;  // ½·log(2π)

struct Component {
    double pi, mu, var;  // weight, mean, variance (≥ floor²)
};

/// A voxel's samples in standardised units: x' = (x − mean)·invScale with scale a power of two
/// in (range, 2·range], so x' ∈ (−1, 1), the scaling is exact, and every σ' lies between
/// floor·invScale ≥ 1e−3·(global range)/(2·voxel range) ≥ 5e−4 and 1: float arithmetic has the
/// same relative accuracy whatever the data's units.
struct Standardise {
    double mean, scale, invScale;
};

Standardise standardise(std::span<const float> sorted) {
    double sum = 0.0;
    for (float v : sorted) sum += v;
    const double mean = sum / static_cast<double>(sorted.size());
    const double range = static_cast<double>(sorted.back()) - sorted.front();
    int e = 0;
    std::frexp(range, &e);  // range < 2^e
    return {mean, std::ldexp(1.0, e), std::ldexp(1.0, -e)};
}

/// k-means++ seeding (Arthur & Vassilvitskii 2007) of a non-constant voxel, then the initial
/// parameters from the hard assignment to the nearest centre (with sorted samples and centres
/// the clusters are runs split at the midpoints; each run holds its centre). Writes d ≤ K
/// components in standardised units and returns d (< K when there are fewer distinct values).
int seedComponents(std::span<const float> x, const Standardise& st, int K, double floorVar,
                   std::uint64_t seed, std::uint64_t stream, Component* comp,
                   std::vector<double>& d2buf) {
    const std::size_t n = x.size();
    const double invN = 1.0 / static_cast<double>(n);
    d2buf.resize(n);
    double* d2 = d2buf.data();
    // Each next centre is a sample drawn with probability ∝ D², its squared distance to the
    // nearest centre chosen so far. Data units, double: the draw does not depend on scaling.
    CounterRng rng(seed, stream, 0);
    std::array<double, kMaxGmmComponents> centre{};
    centre[0] =
        x[std::min(n - 1, static_cast<std::size_t>(rng.uniform() * static_cast<double>(n)))];
    for (std::size_t i = 0; i < n; ++i) d2[i] = (x[i] - centre[0]) * (x[i] - centre[0]);
    int d = 1;
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
        const double var = cnt > 0.0 ? ss / cnt * st.invScale * st.invScale : 0.0;
        comp[k] = {cnt * invN, (mu - st.mean) * st.invScale, std::max(var, floorVar)};
        begin = end;
    }
    return d;
}

/// Writes the 3K outputs of a fit (data units): spare components (k ≥ d) get weight 0 at the
/// sample mean, then all are sorted by mean and the weights normalised.
void finish(const Component* comp, int d, int K, const Standardise& st, double floorSigma,
            std::span<float> out, GmmFitInfo& info) {
    std::array<Component, kMaxGmmComponents> c;  // data units, σ in .var; K used
    for (int k = 0; k < K; ++k) {
        if (k < d)
            c[k] = {comp[k].pi, st.mean + comp[k].mu * st.scale,
                    std::max(std::sqrt(comp[k].var) * st.scale, floorSigma)};
        else
            c[k] = {0.0, st.mean, floorSigma};
    }
    std::stable_sort(c.begin(), c.begin() + K,
                     [](const Component& a, const Component& b) { return a.mu < b.mu; });
    double piSum = 0.0;
    for (int k = 0; k < K; ++k) piSum += c[k].pi;
    info.distinctComponents = 0;
    for (int k = 0; k < K; ++k) {
        if (c[k].pi > 0.0) ++info.distinctComponents;
        out[k] = static_cast<float>(c[k].pi / piSum);
        out[K + k] = static_cast<float>(c[k].mu);
        out[2 * K + k] = static_cast<float>(c[k].var);
    }
}

/// A constant voxel: a point mass (all weight on one component, every μ at the value).
void pointMass(float value, int K, double floorSigma, std::span<float> out, GmmFitInfo& info) {
    for (int k = 0; k < K; ++k) {
        out[k] = k == 0 ? 1.f : 0.f;
        out[K + k] = value;
        out[2 * K + k] = static_cast<float>(floorSigma);
    }
    info = GmmFitInfo{};
    info.distinctComponents = 1;
}

/// EM (Dempster et al. 1977) on many voxels at once, one voxel per vector lane (kLanes): lane l
/// iterates its own voxel; when it stops (converged or at the cap) its result is written and the
/// next voxel is loaded into the lane. Each lane's arithmetic is elementwise, so a voxel's result
/// does not depend on its lane, its neighbours or the thread. KC = K when known at compile time
/// (registers), 0 for any K ≤ kMaxGmmComponents.
///
/// One fused pass per iteration: the E-step's responsibilities at the current parameters are
/// folded straight into the M-step's weighted sums. Per sample, with e_k = log(π_k·N(x|μ_k,σ_k))
/// + ½·log(2π) and m = max_k e_k: r_k = e^{e_k−m} / Σ_j e^{e_j−m} (one fast exp per component,
/// one division), log p(x) = m + log Σ_j e^{e_j−m}. The log is not taken per sample: the sums
/// (each in [1, K]) are multiplied up, their exponent split off every 8 samples, and one log per
/// lane per iteration finishes the log-likelihood. Float inside blocks of 8 samples, double
/// across blocks and for the parameters: the log-likelihood per sample is accurate to ~1e−7,
/// ten times finer than the 1e−6 convergence tolerance.
template <int KC>
void emMany(std::size_t count, std::size_t n, const float* samples, const GmmOptions& opt,
            std::uint64_t firstStream, float* out, GmmFitInfo* infos, GmmWorkspace& ws) {
    constexpr int KA = KC > 0 ? KC : kMaxGmmComponents;
    const int K = KC > 0 ? KC : opt.components;
    const double floorSigma = opt.sigmaFloor;
    const double invN = 1.0 / static_cast<double>(n);
    const std::size_t outStride = static_cast<std::size_t>(3 * K);

    ws.lanes.assign(kLanes * n, 0.f);
    float* X = ws.lanes.data();  // X[kLanes·i + l]: sample i of lane l, standardised

    // Lane state. Parameters, iteration counts, the previous log-likelihood and whether a lane
    // holds a voxel are SoA over lanes (vectors: the per-iteration bookkeeping is a few vector
    // operations, not a loop over lanes); what only loading and finishing a voxel need is per
    // lane. Standardised units.
    struct Lane {
        std::size_t voxel = 0;
        int d = 0;
        Standardise st{};
    };
    std::array<Lane, kLanes> lane{};
    std::array<VD, KA> pi{}, mu{}, var{};
    VD floorVar = splat<VD>(1.0);
    VD prevLl{};      // the previous iteration's mean log-likelihood
    VD iterations{};  // EM iterations run (exact small integers in double)
    VL active{};      // −1: the lane holds a voxel
    std::size_t nextVoxel = 0;

    auto setComponent = [&](int l, int k, const Component& c) {
        pi[k][l] = c.pi;
        mu[k][l] = c.mu;
        var[k][l] = c.var;
    };
    // Loads the next non-constant voxel into lane l (constant ones are finished on the way);
    // an idle lane gets harmless parameters and zero samples.
    auto load = [&](int l) {
        Lane& ln = lane[static_cast<std::size_t>(l)];
        while (nextVoxel < count) {
            const std::size_t v = nextVoxel++;
            const std::span<const float> s(samples + v * n, n);
            const std::span<float> o(out + v * outStride, outStride);
            if (s.front() == s.back()) {
                pointMass(s.front(), K, floorSigma, o, infos[v]);
                continue;
            }
            ln.voxel = v;
            active[l] = -1;
            iterations[l] = 0.0;
            prevLl[l] = 0.0;
            ln.st = standardise(s);
            const double f = floorSigma * ln.st.invScale;
            const double laneFloorVar = f * f;
            floorVar[l] = laneFloorVar;
            std::array<Component, KA> c;
            ln.d = seedComponents(s, ln.st, K, laneFloorVar, opt.seed, firstStream + v, c.data(),
                                  ws.d2);
            for (int k = 0; k < K; ++k)
                setComponent(l, k, k < ln.d ? c[k] : Component{0.0, 0.0, laneFloorVar});
            for (std::size_t i = 0; i < n; ++i)
                X[kLanes * i + static_cast<std::size_t>(l)] =
                    static_cast<float>((s[i] - ln.st.mean) * ln.st.invScale);
            return;
        }
        active[l] = 0;
        for (int k = 0; k < K; ++k) setComponent(l, k, {k == 0 ? 1.0 : 0.0, 0.0, 1.0});
        floorVar[l] = 1.0;
        for (std::size_t i = 0; i < n; ++i) X[kLanes * i + static_cast<std::size_t>(l)] = 0.f;
    };
    for (int l = 0; l < kLanes; ++l) load(l);

    const VF negInf = splat<VF>(-std::numeric_limits<float>::infinity());
    const VD tolerance = splat<VD>(opt.tolerance);
    const VD maxIterations = splat<VD>(static_cast<double>(opt.maxIterations));
    for (;;) {
        bool any = false;
        for (int l = 0; l < kLanes; ++l) any = any || active[l] != 0;
        if (!any) break;

        // Per component: e_k = a_k + b_k·(x − μ_k)², a_k = log π_k − ½·log σ_k², b_k = −½/σ_k².
        // a and b in double, then rounded once: with float logs (errors ~3e−7) EM stopped at a
        // different iteration than a double-precision reference noticeably more often.
        std::array<VF, KA> a, b, m;
        for (int k = 0; k < K; ++k) {
            // One log and one division per component: a = ½·log(π²/σ²), b = −½·(1/σ²).
            const VD invVar = 1.0 / var[k];
            const VD ratio = pi[k] * pi[k] * invVar;
            a[k] = __builtin_convertvector(
                0.5 * detail::logPositiveD(selectBits(less(VD{}, ratio), ratio, splat<VD>(1.0))),
                VF);
            a[k] = selectBits(less(VF{}, __builtin_convertvector(pi[k], VF)), a[k],
                              negInf);  // dead stays dead
            b[k] = __builtin_convertvector(-0.5 * invVar, VF);
            m[k] = __builtin_convertvector(mu[k], VF);
        }
        std::array<VD, KA> nkD{}, s1D{}, s2D{};
        VD maxSum{};
        VI expo{};
        VF prod = splat<VF>(1.f);
        // A block of ≤ 8 samples in two passes: the responsibilities, then the sums. One pass
        // needs more registers than there are (12 sums + the parameters + the exp's constants):
        // GCC kept the sums in memory, a store and a load per sum and sample. Every sum adds
        // the same terms in the same order either way.
        std::array<std::array<VF, KA>, 8> resp;  // r_k of the block's samples
        std::array<VF, 8> maxima;                // m of the block's samples
        for (std::size_t i0 = 0; i0 < n; i0 += 8) {
            const std::size_t i1 = std::min(n, i0 + 8);
            for (std::size_t i = i0; i < i1; ++i) {
                VF xv;
                std::memcpy(&xv, X + kLanes * i, sizeof(VF));
                std::array<VF, KA> e;
                for (int k = 0; k < K; ++k) {
                    const VF dx = xv - m[k];
                    e[k] = a[k] + b[k] * (dx * dx);
                }
                VF mx = e[0];
                for (int k = 1; k < K; ++k) mx = selectBits(less(mx, e[k]), e[k], mx);
                VF sum{};
                for (int k = 0; k < K; ++k) {
                    e[k] = detail::expNonPositive(e[k] - mx);
                    sum += e[k];
                }
                const VF inv = 1.f / sum;  // sum ∈ [1, K]
                for (int k = 0; k < K; ++k) resp[i - i0][k] = e[k] * inv;
                maxima[i - i0] = mx;
                prod *= sum;
            }
            for (int k = 0; k < K; ++k) {
                // Sums about the current μ_k: little cancellation in s2.
                VF nk{}, s1{}, s2{};
                for (std::size_t i = i0; i < i1; ++i) {
                    VF xv;
                    std::memcpy(&xv, X + kLanes * i, sizeof(VF));
                    const VF dx = xv - m[k];
                    const VF dx2 = dx * dx;
                    const VF r = resp[i - i0][k];
                    nk += r;
                    s1 += r * dx;
                    s2 += r * dx2;
                }
                nkD[k] += __builtin_convertvector(nk, VD);
                s1D[k] += __builtin_convertvector(s1, VD);
                s2D[k] += __builtin_convertvector(s2, VD);
            }
            // m in double at once: |m| reaches ~100 (standardised units, far samples), where
            // float sums of even 8 values would err by ~1e−5 per sample, above the tolerance.
            for (std::size_t i = i0; i < i1; ++i)
                maxSum += __builtin_convertvector(maxima[i - i0], VD);
            prod = detail::splitExponent(prod, expo);  // ≤ 8 factors in [1, K]: no overflow
        }
        // Mean log-likelihood per sample (standardised units, without −½·log(2π)).
        const VD ll = (maxSum + __builtin_convertvector(expo, VD) * splat<VD>(0.69314718055994531) +
                       __builtin_convertvector(detail::logPositive(prod), VD)) *
                      splat<VD>(invN);

        // Converged: |Δ ll| < tolerance after at least one iteration (−tol < Δ < tol is
        // |Δ| < tol, NaN included). Lanes that stop are finished with the parameters `ll` was
        // evaluated at, then (after the M-step, which every lane takes: cheaper than selecting)
        // loaded with the next voxel.
        const VD delta = ll - prevLl;
        const VL converged =
            less(VD{}, iterations) & less(delta, tolerance) & less(-tolerance, delta);
        const VL stop = active & (converged | ~less(iterations, maxIterations));
        const VL takeMask = active & ~stop;
        iterations = selectBits(takeMask, iterations + 1.0, iterations);
        prevLl = selectBits(takeMask, ll, prevLl);
        bool anyStop = false;
        for (int l = 0; l < kLanes; ++l) {
            if (stop[l] == 0) continue;
            anyStop = true;
            const Lane& ln = lane[static_cast<std::size_t>(l)];
            GmmFitInfo& info = infos[ln.voxel];
            info.iterations = static_cast<int>(iterations[l]);
            info.converged = converged[l] != 0;
            info.meanLogLikelihood = ll[l] - std::log(ln.st.scale) - kHalfLog2Pi;
            std::array<Component, KA> c;
            for (int k = 0; k < ln.d; ++k) c[k] = {pi[k][l], mu[k][l], var[k][l]};
            finish(c.data(), ln.d, K, ln.st, floorSigma,
                   std::span<float>(out + ln.voxel * outStride, outStride), info);
        }
        // M-step: π = N_k/n, μ += Σ r·(x − μ)/N_k, σ² = max(Σ r·(x − μ)²/N_k − shift², floor²);
        // a component that lost its samples (N_k ≤ 1e−6) gets weight 0 and keeps its mean.
        // Idle lanes (zero samples, one component at 0 with variance 1) stay as they are.
        for (int k = 0; k < K; ++k) {
            const VD nkS = nkD[k];
            const VL live = less(splat<VD>(1e-6), nkS);
            const VD inv = splat<VD>(1.0) / selectBits(live, nkS, splat<VD>(1.0));
            const VD shift = s1D[k] * inv;
            VD v = s2D[k] * inv - shift * shift;
            v = selectBits(less(floorVar, v), v, floorVar);
            const VD muF = __builtin_convertvector(m[k], VD);  // the μ the pass used
            const VD nPi = selectBits(live, nkS * splat<VD>(invN), splat<VD>(0.0));
            const VD nMu = selectBits(live, muF + shift, mu[k]);
            var[k] = selectBits(live, v, floorVar);
            pi[k] = nPi;
            mu[k] = nMu;
        }
        for (int l = 0; anyStop && l < kLanes; ++l)
            if (stop[l] != 0) load(l);
    }
}

void fitMany(std::size_t count, std::size_t n, const float* samples, const GmmOptions& opt,
             std::uint64_t firstStream, float* out, GmmFitInfo* infos, GmmWorkspace& ws) {
    switch (opt.components) {
        case 1:
            return emMany<1>(count, n, samples, opt, firstStream, out, infos, ws);
        case 2:
            return emMany<2>(count, n, samples, opt, firstStream, out, infos, ws);
        case 3:
            return emMany<3>(count, n, samples, opt, firstStream, out, infos, ws);
        case 4:
            return emMany<4>(count, n, samples, opt, firstStream, out, infos, ws);
        default:
            return emMany<0>(count, n, samples, opt, firstStream, out, infos, ws);
    }
}

void checkOptions(const GmmOptions& o, std::size_t n) {
    UDVR_CHECK(o.components >= 1 && o.components <= kMaxGmmComponents);
    // n < K is allowed: at most n distinct values, so as a voxel with fewer distinct values
    // than K (build --nan skip, a voxel with fewer finite members than K).
    UDVR_CHECK(n >= 1 && o.sigmaFloor > 0.0);
}

}  // namespace

GmmFitInfo fitGmm(std::span<const float> sorted, const GmmOptions& options, std::uint64_t stream,
                  std::span<float> out, GmmWorkspace& ws) {
    checkOptions(options, sorted.size());
    UDVR_CHECK(out.size() == static_cast<std::size_t>(3 * options.components));
    GmmFitInfo info;
    fitMany(1, sorted.size(), sorted.data(), options, stream, out.data(), &info, ws);
    return info;
}

void fitGmmMany(std::span<const float> sorted, std::size_t n, const GmmOptions& options,
                std::uint64_t firstStream, std::span<float> out, std::span<GmmFitInfo> info,
                GmmWorkspace& ws) {
    checkOptions(options, n);
    UDVR_CHECK(n > 0 && sorted.size() % n == 0);
    const std::size_t count = sorted.size() / n;
    UDVR_CHECK(out.size() == count * static_cast<std::size_t>(3 * options.components));
    UDVR_CHECK(info.size() == count);
    fitMany(count, n, sorted.data(), options, firstStream, out.data(), info.data(), ws);
}

}  // namespace udvr
