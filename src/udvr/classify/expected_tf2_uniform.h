#pragma once
// E[TF2(X, G)] for the `uniform` model (SPEC §9): (X, G) = (cx, cy) + Σ_i t_i·(a_i, b_i) with
// t_i ~ U[−1, 1] independent, (a_i, b_i) = h_i·(w_i, u_i) (h_i the voxel's half width, w_i its
// trilinear weight, u_i = n̂·g_i): the paper's bivariate box spline with up to 32 directions.
// `uniform` takes expectedTf2UniformExact (expected_tf2_uniform_exact.h: within 1e−6);
// `uniform-fast`, for rendering, is quasi-Monte Carlo over a fixed rank-1 lattice:
// - the points: a Korobov lattice of N = 256 points in [0, 1)³², z_j = a^j mod N, shifted by a
//   fixed random Δ and folded by the tent (baker's) map φ(u) = 1 − |2u − 1|, so that the rule
//   integrates non-periodic integrands at the lattice's rate; t_kj = 2φ({k·z_j/N + Δ_j}) − 1.
//   a minimises the weighted P₂ criterion (weights γ_j = 1/(j + 1)², the first dimensions
//   matter most) over the odd a < N (uniformLattice, built on first use);
// - the directions in decreasing order of their extent in raster cells (|a_i|/Δx + |b_i|/Δy),
//   so the widest take the lattice's best dimensions;
// - E = (1/N) Σ_k TF2(cx + Σ_i t_ki a_i, cy + Σ_i t_ki b_i), premultiplied, over the float
//   raster on lanes (the same cell-level empty skip as every TF2 lookup).
// Error against the exact evaluation and cost: docs/models.md.
#include <algorithm>
#include <bit>
#include <cmath>

#include "udvr/classify/expected_tf2.h"
#include "udvr/classify/expected_tf2_uniform_exact.h"
#include "udvr/util/lanes.h"
#include "udvr/util/random.h"

namespace udvr {

namespace detail {
/// `uniform-fast`'s point set with a TF2 (the header's comment).
struct UniformLattice {
    static constexpr int kPoints = 256, kDims = 32;
    static_assert(kPoints % lanes::kWidth == 0);
    int generator = 0;                    // a: z_j = a^j mod kPoints
    alignas(64) float t[kDims][kPoints];  // t[j][k] ∈ [−1, 1]: dimension j of point k
};

/// The weighted P₂ criterion of the Korobov lattice with generator a over N points in `dims`
/// dimensions: −1 + (1/N) Σ_k Π_j (1 + γ_j·2π²·B₂({k·z_j/N})), B₂(x) = x² − x + 1/6,
/// γ_j = 1/(j + 1)² (the squared worst-case error of the lattice rule in the weighted Korobov
/// space of smoothness 1; smaller is better).
inline double korobovP2(int a, int N, int dims) {
    constexpr double kTwoPiSq = 19.739208802178716;  // 2π²
    double sum = 0.0;
    for (int k = 0; k < N; ++k) {
        double prod = 1.0;
        long long z = 1;  // a^j mod N
        for (int j = 0; j < dims; ++j) {
            const double x = static_cast<double>((k * z) % N) / N;
            prod *= 1.0 + kTwoPiSq * (x * x - x + 1.0 / 6.0) / ((j + 1.0) * (j + 1.0));
            z = (z * a) % N;
        }
        sum += prod;
    }
    return sum / N - 1.0;
}

inline UniformLattice makeUniformLattice() {
    constexpr int N = UniformLattice::kPoints, D = UniformLattice::kDims;
    UniformLattice l;
    double best = 0.0;
    for (int a = 3; a < N; a += 2) {  // odd: every z_j is a unit mod N (a power of 2)
        const double p = korobovP2(a, N, D);
        if (l.generator == 0 || p < best) best = p, l.generator = a;
    }
    long long z = 1;
    for (int j = 0; j < D; ++j) {
        const double shift = CounterRng(2021, 0x1a77, static_cast<std::uint64_t>(j)).uniform();
        for (int k = 0; k < N; ++k) {
            double u = static_cast<double>((k * z) % N) / N + shift;
            u -= std::floor(u);
            l.t[j][k] = static_cast<float>(2.0 * (1.0 - std::abs(2.0 * u - 1.0)) - 1.0);
        }
        z = (z * l.generator) % N;
    }
    return l;
}

/// The lattice, built once.
inline const UniformLattice& uniformLattice() {
    static const UniformLattice lattice = makeUniformLattice();
    return lattice;
}

/// `uniform-fast`: the lattice rule above over the float raster `rf` (`rd`: the same raster in
/// double, for the lookup of non-finite data, as the exact evaluation). Directions with a = b =
/// 0 are left out.
inline void expectedTf2UniformLattice(const Tf2Raster<float>& rf, const Tf2Raster<double>& rd,
                                      double cx, double cy, const BoxDirection2* d, int n,
                                      double out[4]) {
    using lanes::Vf;
    const UniformLattice& lat = uniformLattice();
    // In raster coordinates (s, t) = ((x − x0)/Δx, (y − y0)/Δy): O(raster size), so float
    // keeps them to ~1e−7 of a cell whatever the data's offset and scale.
    const double s0 = (cx - rd.x0) * rd.invDx, t0 = (cy - rd.y0) * rd.invDy;
    constexpr int kMax = UniformLattice::kDims;
    static_assert(kMax % lanes::kWidth == 0);
    double ds[kMax], dt[kMax], es = 0.0, et = 0.0;
    alignas(64) float extent[kMax];  // |ds| + |dt|: raster cells; −1 past n
    for (int i = 0; i < kMax; ++i) extent[i] = -1.0f;
    for (int i = 0; i < n; ++i) {
        ds[i] = d[i].a * rd.invDx;
        dt[i] = d[i].b * rd.invDy;
        es += std::abs(ds[i]);
        et += std::abs(dt[i]);
        extent[i] = static_cast<float>(std::abs(ds[i]) + std::abs(dt[i]));
    }
    if (!(std::abs(s0) + std::abs(t0) + es + et < 1e30)) {  // NaN, inf or beyond float
        tf2At<double>(rd, cx, cy, true, out);               // the lookup at the centre
        return;
    }
    for (int ch = 0; ch < 4; ++ch) out[ch] = 0.0;
    if (rf.cellEmptyDistance) {  // every point within |s − s0| ≤ es, |t − t0| ≤ et, clamped
        const int i = std::min(static_cast<int>(std::clamp(s0, 0.0, rf.width - 1.0)), rf.width - 2);
        const int j =
            std::min(static_cast<int>(std::clamp(t0, 0.0, rf.height - 1.0)), rf.height - 2);
        const double empty = rf.cellEmptyDistance[j * (rf.width - 1) + i];
        if (es + 1.0 < empty && et + 1.0 < empty) return;  // only cells with α = 0 there
    }
    // The directions by decreasing extent (ties by index), those of extent 0 left out: each
    // one's rank is the count of those before it.
    int order[kMax], m = 0;
    {
        lanes::Vf ev[kMax / lanes::kWidth];
        for (int v = 0; v < kMax / lanes::kWidth; ++v)
            ev[v] = lanes::load(extent + v * lanes::kWidth);
        for (int i = 0; i < n; ++i) {
            if (!(extent[i] > 0.0f)) continue;
            const lanes::Vf e = lanes::splat<lanes::Vf>(extent[i]);
            int rank = 0;
            for (int v = 0; v < kMax / lanes::kWidth; ++v) {
                const lanes::Vi index = lanes::iota() + v * lanes::kWidth;
                rank += std::popcount(lanes::bits((ev[v] > e) | ((ev[v] == e) & (index < i))));
            }
            order[rank] = i;
            ++m;
        }
    }
    Tf2Raster<float> unit = rf;  // looked up at raster coordinates
    unit.x0 = unit.y0 = 0.0f;
    unit.invDx = unit.invDy = 1.0f;
    const Vf sc = lanes::splat<Vf>(static_cast<float>(s0)),
             tc = lanes::splat<Vf>(static_cast<float>(t0));
    if (m == 0) {  // no width: the point (cx, cy)
        Vf v[4];
        tf2At<Vf>(unit, sc, tc, lanes::allTrue<Vf>(), v);
        for (int ch = 0; ch < 4; ++ch) out[ch] = static_cast<double>(v[ch][0]);
        return;
    }
    float fs[kMax], ft[kMax];
    for (int j = 0; j < m; ++j)
        fs[j] = static_cast<float>(ds[order[j]]), ft[j] = static_cast<float>(dt[order[j]]);
    Vf acc[4] = {};
    // Blocks of kChunk × kWidth points share each direction's broadcast.
    constexpr int kChunk = 4, kStep = kChunk * lanes::kWidth;
    static_assert(UniformLattice::kPoints % kStep == 0);
    for (int k = 0; k < UniformLattice::kPoints; k += kStep) {
        Vf s[kChunk] = {}, t[kChunk] = {};
        for (int j = 0; j < m; ++j) {
            const Vf a = lanes::splat<Vf>(fs[j]), b = lanes::splat<Vf>(ft[j]);
            for (int c = 0; c < kChunk; ++c) {
                const Vf tj = lanes::load(&lat.t[j][k + c * lanes::kWidth]);
                s[c] = lanes::fma(a, tj, s[c]);
                t[c] = lanes::fma(b, tj, t[c]);
            }
        }
        for (int c = 0; c < kChunk; ++c) {
            Vf v[4];
            tf2At<Vf>(unit, sc + s[c], tc + t[c], lanes::allTrue<Vf>(), v);
            for (int ch = 0; ch < 4; ++ch) acc[ch] += v[ch];
        }
    }
    for (int ch = 0; ch < 4; ++ch)
        out[ch] = static_cast<double>(lanes::sum(acc[ch])) / UniformLattice::kPoints;
}
}  // namespace detail

/// E[(α·c, α)(X, G)] for (X, G) = (cx, cy) + Σ_i t_i·d_i by expectedTf2UniformExact over `rd`:
/// `exact` (the `uniform-exact` model) at its defaults (error ≤ 1e−6), else (`uniform`, since
/// issue 33) at the coarser kUniform2DFast settings (measured max 1.8e−4 from the converged
/// value over random rough rasters, ~11× cheaper; docs/models.md). The lattice rule above (the
/// 2D `uniform-fast` before issue 33, error up to 2.3e−2) is no model's evaluation any more.
inline constexpr Tf2UniformExactOptions kUniform2DFast{32, 1e-5, 2};
inline void expectedTf2Uniform(const Tf2Raster<double>& rd, double cx, double cy,
                               const BoxDirection2* d, int n, bool exact, double tinyWidth,
                               double out[4]) {
    Tf2UniformExactOptions opt = exact ? Tf2UniformExactOptions{} : kUniform2DFast;
    expectedTf2UniformExact(rd, cx, cy, d, n, tinyWidth, opt, out);
}

}  // namespace udvr
