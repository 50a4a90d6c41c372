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

// e^x for x ≤ 0, relative error < 1e−14 down to x = −708 (clamped there: e^−708 ≈ 3e−308 is
// negligible next to the row maximum's e^0 = 1). Branch-free so that the E-step loops vectorise:
// x = n·ln2 + r with |r| ≤ ln2/2, e^r by its degree-11 Taylor polynomial, 2^n from the bits.
inline double expNonPositive(double x) {
    x = x < -708.0 ? -708.0 : x;
    const double n = std::floor(x * 1.4426950408889634 + 0.5);
    const double r = (x - n * 0.693147180369123816490) - n * 1.90821492927058770002e-10;
    double p = 1.0 / 39916800.0;
    p = p * r + 1.0 / 3628800.0;
    p = p * r + 1.0 / 362880.0;
    p = p * r + 1.0 / 40320.0;
    p = p * r + 1.0 / 5040.0;
    p = p * r + 1.0 / 720.0;
    p = p * r + 1.0 / 120.0;
    p = p * r + 1.0 / 24.0;
    p = p * r + 1.0 / 6.0;
    p = p * r + 0.5;
    p = p * r + 1.0;
    p = p * r + 1.0;
    // n + 1023 ∈ [2, 1023] sits in the low mantissa bits of n + (2^52 + 1023).
    const std::uint64_t biased = std::bit_cast<std::uint64_t>(n + (0x1p52 + 1023.0));
    return p * std::bit_cast<double>(biased << 52);
}

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

        // EM (Dempster et al. 1977) on d components; responsibilities stored component-major.
        const std::size_t dn = static_cast<std::size_t>(d) * n;
        ws.logp.resize(dn);
        ws.resp.resize(dn);
        ws.rowMax.resize(n);
        ws.rowInv.resize(n);
        double* logp = ws.logp.data();
        double* resp = ws.resp.data();
        double* rowMax = ws.rowMax.data();
        double* rowInv = ws.rowInv.data();

        // E-step: responsibilities for the current parameters; returns the mean log-likelihood
        // per sample without the constant −½·log(2π).
        auto eStep = [&]() {
            for (int k = 0; k < d; ++k) {
                const double a = std::log(std::max(comp[k].pi, 1e-300)) - std::log(comp[k].sigma);
                const double b = -0.5 / (comp[k].sigma * comp[k].sigma);
                const double mu = comp[k].mu;
                double* row = logp + static_cast<std::size_t>(k) * n;
                for (std::size_t i = 0; i < n; ++i) {
                    const double dx = x[i] - mu;
                    row[i] = a + b * dx * dx;
                }
            }
            for (std::size_t i = 0; i < n; ++i) rowMax[i] = logp[i];
            for (int k = 1; k < d; ++k) {
                const double* row = logp + static_cast<std::size_t>(k) * n;
                for (std::size_t i = 0; i < n; ++i) rowMax[i] = std::max(rowMax[i], row[i]);
            }
            for (std::size_t i = 0; i < n; ++i) rowInv[i] = 0.0;
            for (int k = 0; k < d; ++k) {
                const double* row = logp + static_cast<std::size_t>(k) * n;
                double* r = resp + static_cast<std::size_t>(k) * n;
                for (std::size_t i = 0; i < n; ++i) {
                    r[i] = expNonPositive(row[i] - rowMax[i]);
                    rowInv[i] += r[i];
                }
            }
            // Σ log(row sums): each sum is in [1, d], so products of 32 stay below 2^160.
            double ll = 0.0;
            for (std::size_t i0 = 0; i0 < n; i0 += 32) {
                const std::size_t i1 = std::min(n, i0 + 32);
                double prod = 1.0;
                for (std::size_t i = i0; i < i1; ++i) {
                    ll += rowMax[i];
                    prod *= rowInv[i];
                }
                ll += std::log(prod);
            }
            for (std::size_t i = 0; i < n; ++i) rowInv[i] = 1.0 / rowInv[i];
            for (int k = 0; k < d; ++k) {
                double* r = resp + static_cast<std::size_t>(k) * n;
                for (std::size_t i = 0; i < n; ++i) r[i] *= rowInv[i];
            }
            return ll * invN;
        };
        // M-step: weighted moments; a component that lost all its samples keeps its mean.
        auto mStep = [&]() {
            for (int k = 0; k < d; ++k) {
                const double* r = resp + static_cast<std::size_t>(k) * n;
                double nk = 0.0, sx = 0.0;
                for (std::size_t i = 0; i < n; ++i) {
                    nk += r[i];
                    sx += r[i] * x[i];
                }
                if (!(nk > 1e-12)) {
                    comp[k] = {0.0, comp[k].mu, floorSigma};
                    continue;
                }
                const double mu = sx / nk;
                double ss = 0.0;
                for (std::size_t i = 0; i < n; ++i) ss += r[i] * (x[i] - mu) * (x[i] - mu);
                comp[k] = {nk * invN, mu, std::max(std::sqrt(ss / nk), floorSigma)};
            }
        };

        double prev = 0.0;
        for (;;) {
            const double ll = eStep();
            info.meanLogLikelihood = ll - 0.91893853320467274178;  // −½·log(2π)
            if (info.iterations > 0 && std::fabs(ll - prev) < options.tolerance) break;
            if (info.iterations >= options.maxIterations) {
                info.converged = false;
                break;
            }
            mStep();
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
