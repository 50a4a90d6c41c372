#pragma once
// Expected transfer function E[TF(X)] = ∫ TF(x) pdf_X(x) dx (Athawale et al. 2021, Eq. 3; SPEC §4)
// for each family of reconstructed distributions, against the exact pieces of tf_pieces.h.
// Channels are (α·r, α·g, α·b, α); results before opacity correction.
//
// Each body is written once over a value type T: double (the exact path, probe and references),
// float (one GPU thread) or lanes::Vf (16 samples of the CPU batch, with a mask of live lanes).
// Branches are taken per lane with masks; `if (anyOf(m))` skips work no lane needs, which for
// scalars is the plain branch. Closed forms throughout: exact up to the rounding of T, except
// where a comment states an error.
#include <cmath>
#include <new>

#include "udvr/classify/tf_pieces.h"
#include "udvr/reconstruct/box_spline.h"
#include "udvr/reconstruct/quantile_interp.h"
#include "udvr/util/fast_math.h"
#include "udvr/util/lanes.h"
#include "udvr/util/normal_cdf.h"

namespace udvr {

/// Beyond this many σ the Gaussian's mass (2·Φ(−7) ≈ 2.6e−12) is integrated against the
/// nearest TF piece inside (extended as a polynomial), so the cutoff error is < 1e−10.
inline constexpr double kGaussianCutoffSigmas = 7.0;

namespace detail {
using lanes::fma;
using lanes::select;

/// The TF view whose real type matches T.
template <class T>
using TfFor = TfPieces<lanes::ScalarOf<T>>;

/// Smallest kl / largest kh over the live lanes (scalars: the value).
UDVR_CPU_GPU inline int lowestOf(int k, bool) { return k; }
inline int lowestOf(lanes::Vi k, lanes::Mask live) { return lanes::minOf(k, live); }
UDVR_CPU_GPU inline int highestOf(int k, bool) { return k; }
inline int highestOf(lanes::Vi k, lanes::Mask live) { return lanes::maxOf(k, live); }

/// Φ(z), 1 − Φ(z), φ(z) and whether z ≥ 0 on T: util/normal_cdf.h's normalAt with the lanes'
/// exponential (std::exp on scalars).
template <class T>
UDVR_CPU_GPU UDVR_INLINE NormalAt<T> normalOf(T z) {
    return normalAt(z, ExpNonPositiveOf{});
}
}  // namespace detail

/// TF(x): (α·c, α) from the piece's lines, premultiplied.
template <class T, class Tf>
UDVR_CPU_GPU UDVR_INLINE void tfAt(const Tf& tf, T x, T out[4]) {
    const auto k = tf.pieceOf(x);
    const T dx = x - tf.at(kTfOrigin, k);
    const T a = lanes::fma(tf.at(kTfAlphaSlope, k), dx, tf.at(kTfAlpha0, k));
    for (int ch = 0; ch < 3; ++ch)
        out[ch] = a * lanes::fma(tf.at(kTfColorSlope + ch, k), dx, tf.at(kTfColor0 + ch, k));
    out[3] = a;
}

/// The piece polynomials of piece k at x (x in or near piece k).
template <class T, class Tf, class K>
UDVR_CPU_GPU UDVR_INLINE void tfPolynomialAt(const Tf& tf, K k, T x, T out[4]) {
    const T t = x - tf.at(kTfOrigin, k);
    for (int ch = 0; ch < 4; ++ch)
        out[ch] = lanes::fma(t, lanes::fma(t, tf.at(kTfC + ch, k), tf.at(kTfB + ch, k)),
                             tf.at(kTfA + ch, k));
}

/// Mean of TF over [lo, hi] given the pieces kl, kh of lo and hi; TF(hi) where hi ≤ lo.
/// Partial pieces at both ends plus the prefix-sum difference of the full pieces between
/// them, so tiny intervals never suffer cancellation.
template <class T, class Tf, class K>
UDVR_CPU_GPU UDVR_INLINE void tfMeanOver(const Tf& tf, T lo, T hi, K kl, K kh, T out[4]) {
    using S = lanes::ScalarOf<T>;
    using detail::fma;
    // ∫ of a + b·t + c·t² over [tl, th] divided by th − tl: a + b·s1 + c·s2.
    const auto moments = [](T tl, T th, T& s1, T& s2) {
        s1 = (tl + th) * S(0.5);
        s2 = fma(tl, tl, fma(tl, th, th * th)) * S(1.0 / 3.0);
    };
    const auto poly = [&](int ch, K k, T s1, T s2) {
        return fma(tf.at(kTfC + ch, k), s2, fma(tf.at(kTfB + ch, k), s1, tf.at(kTfA + ch, k)));
    };
    const T ol = tf.at(kTfOrigin, kl);
    const T tl = lo - ol;
    T s1, s2;
    moments(tl, hi - ol, s1, s2);
    for (int ch = 0; ch < 4; ++ch) out[ch] = poly(ch, kl, s1, s2);  // lo, hi on one piece
    const auto empty = !(hi > lo);
    const auto span = (kl != kh) & !empty;
    if (lanes::anyOf(empty)) {  // TF(hi)
        T v[4];
        tfPolynomialAt<T>(tf, kh, hi, v);
        for (int ch = 0; ch < 4; ++ch) out[ch] = detail::select(empty, v[ch], out[ch]);
    }
    if (lanes::anyOf(span)) {
        // Left: [lo, u_kl] on piece kl; right: [origin_kh, hi] on piece kh; between: the full
        // pieces kl+1 … kh−1, cum[kh] − cum[kl+1].
        const T end = tf.at(kTfBound, kl);
        const T wl = end - lo, tr = hi - tf.at(kTfOrigin, kh);
        T ls1, ls2, rs1, rs2;
        moments(tl, end - ol, ls1, ls2);
        moments(T{}, tr, rs1, rs2);
        const K next = kl + 1;
        const T inv = S(1) / (hi - lo);
        for (int ch = 0; ch < 4; ++ch) {
            const T full = (tf.at(kTfCum + ch, kh) - tf.at(kTfCum + ch, next)) +
                           (tf.at(kTfCumLo + ch, kh) - tf.at(kTfCumLo + ch, next));
            const T v = (wl * poly(ch, kl, ls1, ls2) + full + tr * poly(ch, kh, rs1, rs2)) * inv;
            out[ch] = detail::select(span, v, out[ch]);
        }
    }
}

/// Quantile-range expectation (Eq. 4) over the count − 1 quantiles between boundaries
/// boundary(0) ≤ … ≤ boundary(count−1), quantile j weighted by its mass (levels; equal for even
/// levels): Σ_j mass_j × (mean of TF over [b_{j−1}, b_j]) / Σ mass; a zero-width quantile
/// contributes TF(b_j). O(count).
template <class T, class Tf, class Boundary>
UDVR_CPU_GPU UDVR_INLINE void expectedTfQuantileRange(const Tf& tf, const Boundary& boundary,
                                                      int count, const QuantileLevels& levels,
                                                      T out[4]) {
    using S = lanes::ScalarOf<T>;
    for (int ch = 0; ch < 4; ++ch) out[ch] = T{};
    T bPrev = boundary(0);
    auto kPrev = tf.pieceOf(bPrev);
    for (int j = 1; j < count; ++j) {
        const T b = boundary(j);
        const auto k = tf.pieceOf(b);
        T m[4];
        tfMeanOver<T>(tf, bPrev, b, kPrev, k, m);
        const T mass = lanes::splat<T>(static_cast<S>(levels.mass(j)));  // 1: exactly out + m
        for (int ch = 0; ch < 4; ++ch) out[ch] = lanes::fma(mass, m[ch], out[ch]);
        kPrev = k;
        bPrev = b;
    }
    const S inv = levels.template inverseTotal<S>(count);
    for (int ch = 0; ch < 4; ++ch) out[ch] *= inv;
}

/// Eq. 5's weights (SPEC §4 quantile-mean), the one body for the lanes (1D TF and TF2) and the
/// distributions' masses (1D and 2D): calls visit(j, p_j) for quantiles j = 0 … q − 1 in order
/// and returns Σ_j p_j, the normaliser (quantile j's share is p_j / Σ). p_j = m_j/w_j with
/// density weights (m_j = levels.mass(j + 1), 1 for even levels where 1/q cancels; w_j =
/// width(j), interpolated from the corners' own widths so that 1/w does not magnify the
/// rounding of large boundaries), else m_j (`quantile-mean-mass`; width is not called). With
/// density weights, a quantile of width ≤ zeroWidth is a point mass of infinite density, and in
/// a point with such quantiles the point masses take all the weight by their masses: p_j = m_j
/// at zero widths and 0 elsewhere. That is found after a first pass over the quantiles; then
/// restart(pointMasses) is called and every j is visited again, with those weights in the
/// `pointMasses` lanes and 0 in the others (which keep the first pass's sums), so the first
/// pass keeps the point masses' sums out of its live vectors (few enough for AVX2's 16
/// registers). Only `live` lanes are looked at for zero widths (dead lanes of a batch have
/// width 0 and would send every quantile down the zero-width path).
template <class T, class Width, class Visit, class Restart>
UDVR_CPU_GPU UDVR_INLINE T forEachQuantileMeanWeight(const Width& width, int q,
                                                     const QuantileLevels& levels,
                                                     bool densityWeights, T zeroWidth,
                                                     lanes::MaskOf<T> live, const Visit& visit,
                                                     const Restart& restart) {
    using S = lanes::ScalarOf<T>;
    T total{};
    auto pointMasses = lanes::MaskOf<T>{};
    for (int j = 0; j < q; ++j) {
        const T m = lanes::splat<T>(static_cast<S>(levels.mass(j + 1)));  // 1 for even: exact
        T p = m;
        if (densityWeights) {
            const T w = width(j);
            p = m / w;
            pointMasses = pointMasses | (live & (w <= zeroWidth));
        }
        visit(j, p);
        total += p;
    }
    if (!densityWeights || !lanes::anyOf(pointMasses)) return total;
    restart(pointMasses);
    total = lanes::select(pointMasses, T{}, total);
    for (int j = 0; j < q; ++j) {
        const T m = lanes::splat<T>(static_cast<S>(levels.mass(j + 1)));
        const T p = lanes::select(pointMasses & (width(j) <= zeroWidth), m, T{});
        visit(j, p);
        total += p;
    }
    return total;
}

/// Eq. 5's masses of quantiles 0 … q − 1 of one point (`width(j)` the width of quantile j, data
/// units): emit(j, p_j / Σ p) with forEachQuantileMeanWeight's p_j, every j in order (mass 0
/// included). The distributions' (1D and 2D) reading of Eq. 5, without storage (the bivariate
/// kernel describes a distribution per sample): one run for Σ p, a second that emits from its
/// last pass (the point masses' pass where the body restarts).
template <class Width, class Emit>
void quantileMeanMasses(const QuantileLevels& levels, int q, bool densityWeights, double zeroWidth,
                        const Width& width, const Emit& emit) {
    bool restarts = false;
    const double total = forEachQuantileMeanWeight<double>(
        width, q, levels, densityWeights, zeroWidth, true, [](int, double) {},
        [&](bool) { restarts = true; });
    bool emitting = !restarts;
    forEachQuantileMeanWeight<double>(
        width, q, levels, densityWeights, zeroWidth, true,
        [&](int j, double pj) {
            if (emitting) emit(j, pj / total);
        },
        [&](bool) { emitting = true; });
}

/// Eq. 5's weighting, for any classification of the quantiles (1D TF or TF2): Σ_j v_j·p_j / Σ p_j
/// over quantiles j = 0 … q − 1 with forEachQuantileMeanWeight's p_j, valueAt(j, v) writing v_j
/// (the TF at quantile j's midpoint). valueAt is called for j = 0, 1, … in order, and once more
/// from j = 0 where some live lane has point masses (the rare second pass).
template <class T, class ValueAt, class Width>
UDVR_CPU_GPU UDVR_INLINE void quantileMeanWeighted(const ValueAt& valueAt, const Width& width,
                                                   int q, const QuantileLevels& levels,
                                                   bool densityWeights, T zeroWidth,
                                                   lanes::MaskOf<T> live, T out[4]) {
    T sum[4] = {};
    const T total = forEachQuantileMeanWeight<T>(
        width, q, levels, densityWeights, zeroWidth, live,
        [&](int j, T p) UDVR_INLINE_LAMBDA {
            T v[4];
            valueAt(j, v);
            for (int ch = 0; ch < 4; ++ch) sum[ch] = lanes::fma(p, v[ch], sum[ch]);
        },
        [&](lanes::MaskOf<T> pointMasses) UDVR_INLINE_LAMBDA {
            for (int ch = 0; ch < 4; ++ch) sum[ch] = lanes::select(pointMasses, T{}, sum[ch]);
        });
    for (int ch = 0; ch < 4; ++ch) out[ch] = sum[ch] / total;
}

/// Quantile-mean expectation (Eq. 5) with a 1D TF: quantileMeanWeighted of TF(m_j), m_j the
/// midpoint of quantile j between boundaries boundary(0 … q).
template <class T, class Tf, class Boundary, class Width>
UDVR_CPU_GPU UDVR_INLINE void expectedTfQuantileMean(const Tf& tf, const Boundary& boundary,
                                                     const Width& width, int q,
                                                     const QuantileLevels& levels,
                                                     bool densityWeights, T zeroWidth,
                                                     lanes::MaskOf<T> live, T out[4]) {
    using S = lanes::ScalarOf<T>;
    T bPrev{};
    quantileMeanWeighted<T>(
        [&](int j, T v[4]) {
            if (j == 0) bPrev = boundary(0);
            const T b = boundary(j + 1);
            tfAt<T>(tf, (bPrev + b) * S(0.5), v);
            bPrev = b;
        },
        width, q, levels, densityWeights, zeroWidth, live, out);
}

/// E[TF(X)], X ~ N(μ, σ²), in the `live` lanes; σ ≤ 0 (or NaN) is the point mass TF(μ). Per TF
/// piece from the one of μ − 7σ to the one of μ + 7σ, the polynomial a + b·t + c·t² integrates
/// against φ in closed form from Φ and φ at the piece ends; differences of Φ in the upper half
/// are taken between upper tails (1 − Φ), so no lane loses digits to 1 − tiny. On float lanes
/// the result has error ~6e−8·(σ/w)² for a piece of width w: callers keep σ ≤ 8·(narrowest
/// piece) in float (kMaxFloatSigmaOverPiece) and take the double body beyond.
template <class T, class Tf>
UDVR_CPU_GPU UDVR_INLINE void expectedTfGaussian(const Tf& tf, T mu, T sigma, lanes::MaskOf<T> live,
                                                 T out[4]) {
    using S = lanes::ScalarOf<T>;
    using detail::fma;
    sigma = detail::select(sigma > S(0), sigma, T{});
    const T var = sigma * sigma;
    const T cutoff = sigma * S(kGaussianCutoffSigmas);
    const auto kl = tf.pieceOf(mu - cutoff);
    const auto kh = tf.pieceOf(mu + cutoff);
    {  // one piece (also σ = 0, where kl = kh = μ's piece): E[p(X)] = p(μ) + c·σ²
        const T d = mu - tf.at(kTfOrigin, kl);
        for (int ch = 0; ch < 4; ++ch) {
            const T c = tf.at(kTfC + ch, kl);
            out[ch] = fma(c, var, fma(d, fma(d, c, tf.at(kTfB + ch, kl)), tf.at(kTfA + ch, kl)));
        }
    }
    const auto spread = live & (kl != kh);
    if (!lanes::anyOf(spread)) return;
    for (int ch = 0; ch < 4; ++ch) out[ch] = detail::select(spread, T{}, out[ch]);
    // Φ, 1 − Φ, φ, z·φ and z ≥ 0 at the left end z_a of the current piece; a lane's first piece
    // starts at z = −∞.
    T cdfA{}, upA = lanes::splat<T>(S(1)), pdfA{}, zpdfA{};
    auto upperA = lanes::MaskOf<T>{};
    const T invSigma = S(1) / sigma;
    const int kFirst = detail::lowestOf(kl, spread), kLast = detail::highestOf(kh, spread);
    for (int k = kFirst; k <= kLast; ++k) {
        // Pieces where the TF is 0 add nothing, and Φ at a bound between two of them is never
        // read (a lane's next non-zero piece starts at a bound computed below).
        const bool zeroHere = tf.at(kTfZero, k) != 0;
        if (zeroHere && (k == kLast || tf.at(kTfZero, k + 1) != 0)) continue;
        const auto on = spread & (kl <= k) & (kh >= k);
        if (!lanes::anyOf(on)) continue;
        const auto last = on & (kh == k);
        const auto mid = on & !last;
        // z_b at the piece's right end u_k (k < kh), +∞ for the lane's last piece.
        T cdfB = lanes::splat<T>(S(1)), upB{}, pdfB{}, zpdfB{};
        auto upperB = last;
        if (lanes::anyOf(mid)) {
            const T z = (lanes::splat<T>(tf.at(kTfBound, k)) - mu) * invSigma;
            const NormalAt<T> n = detail::normalOf(z);
            cdfB = detail::select(mid, n.cdf, cdfB);
            upB = detail::select(mid, n.upper, upB);
            pdfB = detail::select(mid, n.pdf, pdfB);
            zpdfB = detail::select(mid, z * n.pdf, zpdfB);
            upperB = last | (mid & n.nonNegative);
        }
        // ∫ z^m φ over [z_a, z_b]: m0 = ΔΦ (between upper tails where z_a ≥ 0),
        // m1 = φ(z_a) − φ(z_b), m2 = m0 + z_a φ(z_a) − z_b φ(z_b).
        const T m0 = detail::select(upperA, upA - upB, cdfB - cdfA);
        const T m1 = pdfA - pdfB;
        const T m2 = m0 + (zpdfA - zpdfB);
        const T d = mu - tf.at(kTfOrigin, k);  // x − origin = d + σz
        for (int ch = 0; ch < 4 && !zeroHere; ++ch) {
            const S pa = tf.at(kTfA + ch, k), pb = tf.at(kTfB + ch, k), pc = tf.at(kTfC + ch, k);
            const T a =
                fma(d, fma(d, lanes::splat<T>(pc), lanes::splat<T>(pb)), lanes::splat<T>(pa));
            const T b = fma(lanes::splat<T>(pc + pc), d, lanes::splat<T>(pb)) * sigma;
            const T c = var * pc;
            out[ch] = detail::select(on, out[ch] + fma(a, m0, fma(b, m1, c * m2)), out[ch]);
        }
        cdfA = detail::select(on, cdfB, cdfA);
        upA = detail::select(on, upB, upA);
        pdfA = detail::select(on, pdfB, pdfA);
        zpdfA = detail::select(on, zpdfB, zpdfA);
        upperA = (upperA & !on) | (upperB & on);
    }
}

/// Float lanes with σ above this many times the TF's narrowest piece take the double Gaussian
/// body: the float closed form loses (σ/w)²× its rounding (0.15 at σ = 1000·w; < 4e−6 at 8·w).
inline constexpr float kMaxFloatSigmaOverPiece = 8.f;

/// E[TF(X)] for a sum of scaled uniforms (box spline), exact, in double: TF = p_0 +
/// Σ_{breaks u in the support} Σ_d Δ_d·(x − u)_+^d with p_0 the quadratic of the support's first
/// piece, so E[TF(X)] = E[p_0(X)] (from mean and variance) + Σ Δ_d·E[(X − u)_+^d]
/// (BoxSplineTail).
UDVR_CPU_GPU inline void expectedTfUniformSum(const TfPieces<double>& tf, const UniformSum& u,
                                              double out[4]) {
    if (u.n == 0) {
        tfPolynomialAt<double>(tf, tf.pieceOf(u.shift), u.shift, out);
        return;
    }
    const double lo = u.shift, hi = u.shift + u.total;
    const int kl = tf.pieceOf(lo), kh = tf.pieceOf(hi);
    const double et = u.mean() - tf.at(kTfOrigin, kl), et2 = u.variance() + et * et;
    for (int ch = 0; ch < 4; ++ch)
        out[ch] = tf.at(kTfA + ch, kl) + tf.at(kTfB + ch, kl) * et + tf.at(kTfC + ch, kl) * et2;
    if (kl == kh) return;
    // Breaks where the TF's polynomial does not change (e.g. a colour point where α = 0 on both
    // sides, so α·c is 0 throughout) add nothing: skip them, and build the tail only if needed.
    alignas(BoxSplineTail) unsigned char storage[sizeof(BoxSplineTail)];
    const BoxSplineTail* tail = nullptr;
    for (int k = kl; k < kh; ++k) {
        const double x = tf.at(kTfBound, k);  // piece k ends, piece k+1 (origin x) starts
        const double len = x - tf.at(kTfOrigin, k);
        double da[4], db[4], dc[4];
        bool any = false;
        for (int ch = 0; ch < 4; ++ch) {
            // Piece k re-expanded about x, subtracted from piece k+1.
            const double pa = tf.at(kTfA + ch, k), pb = tf.at(kTfB + ch, k),
                         pc = tf.at(kTfC + ch, k);
            da[ch] = tf.at(kTfA + ch, k + 1) - (pa + len * (pb + len * pc));
            db[ch] = tf.at(kTfB + ch, k + 1) - (pb + 2.0 * len * pc);
            dc[ch] = tf.at(kTfC + ch, k + 1) - pc;
            any = any || da[ch] != 0.0 || db[ch] != 0.0 || dc[ch] != 0.0;
        }
        if (!any) continue;
        if (tail == nullptr) tail = new (storage) BoxSplineTail(u);
        double t[3];
        tail->at(u.shift - x, t);  // E[(X − x)_+^d]
        for (int ch = 0; ch < 4; ++ch) out[ch] += da[ch] * t[0] + db[ch] * t[1] + dc[ch] * t[2];
    }
}

namespace detail {
/// Beyond this many σ the remainder of BoxSplineFast is taken as entirely on one side (its
/// Gaussian mass beyond 7σ, 1.3e−12, is dropped): the moments' closed form then replaces a
/// divided difference that would lose digits (level one below). The 2D kernel's cutoff
/// (expected_tf2_fast.h); the 1D kernel cuts at kBoxSplineNearSigmas.
inline constexpr double kBoxSplineCutoffSigmas = 7.0;
/// expectedTfUniformFast's cutoff: a node of a break beyond 5σ takes Φ, φ as 0 or 1, 0 without
/// evaluating them (on lanes they are evaluated for the other nodes only, packed into full
/// vectors: about half the nodes of the tangle are outside). The remainder R it stands for lies
/// within 4.25σ (six equal boxes: 3h against σ = h/√2), so past 5σ only the surrogate's own tail
/// is dropped: its Gaussian mass 2.9e−7 and Edgeworth terms < 4e−6 (k4²·He5·φ at 5σ); the
/// error against the exact kernel is unchanged (docs/models.md).
inline constexpr double kBoxSplineNearSigmas = kNormalNearRange;

/// What the tail of BoxSplineFast needs per sample, in units of the remainder's σ (z = t/σ).
/// K44: the remainder's density is the Edgeworth series to second order, φ·(1 + k4·He4 +
/// k6·He6 + (k4²/2)·He8) (the 2D kernel), or without its κ4² term (K44 = false: the Gram–Charlier
/// A series through He6, which matches R's first six moments; expectedTfUniformFast, where it
/// halves the error against the exact box spline, docs/models.md).
template <class T, bool K44 = true>
struct BoxSplineFastScaled {
    T invSigma, h1, h2, invH1, invH2;  // h/σ and σ/h
    T k4;                              // κ4/(24σ⁴)
    T c0, c1, c2, d0, d1, d2, f0, f1;  // the Edgeworth polynomials' coefficients (remainderTail)
    T w1, w2, w3;                      // E[W^i]/i! of W = (h2·U2 + R)/σ, i = 1, 2, 3

    UDVR_CPU_GPU explicit BoxSplineFastScaled(const BoxSplineFast<T>& b) {
        using S = lanes::ScalarOf<T>;
        invSigma = S(1) / b.sigma;
        h1 = b.h1 * invSigma;
        h2 = b.h2 * invSigma;
        invH1 = b.sigma / b.h1;
        invH2 = b.sigma / b.h2;
        k4 = b.k4;
        const T k6 = b.k6, k44 = K44 ? b.k4 * b.k4 * S(0.5) : T{};  // κ4²/(1152σ⁸)
        c0 = k4 - S(3) * k6 + S(15) * k44, c1 = k6 - S(10) * k44, c2 = k44;
        d0 = k4 - k6 + S(3) * k44, d1 = k6 - S(6) * k44, d2 = k44;
        f0 = k6 - S(3) * k44, f1 = k44;
        w1 = h2 * S(0.5);
        w2 = lanes::fma(h2 * h2, lanes::splat<T>(S(1.0 / 6.0)), lanes::splat<T>(S(0.5)));
        w3 = lanes::fma(h2 * h2 * h2, lanes::splat<T>(S(1.0 / 24.0)), w1 * S(0.5));
    }
};

/// E[(σz + R)_+^j]/(j!·σ^j), j = 2, 3, 4, for R of BoxSplineFast, from Φ(z) and φ(z): M_j(z) of
/// the standard normal (M_0 = Φ, M_1 = zΦ + φ, j·M_j = z·M_{j−1} + M_{j−2}) plus the density's
/// correction terms, k4·S(j−4) + k6·S(j−6) (+ (k4²/2)·S(j−8) where K44) with S(0) = Φ and
/// S(−k) = (−1)^{k−1} He_{k−1}(z)·φ(z) (the k−1'th derivative of the density; k6 = κ6/(720σ⁶)),
/// folded into polynomials in z. With Φ = [z ≥ 0] and φ = 0 it is the one-sided limit (0, or
/// the moments' polynomial). Absolute error ~ε (for z ≪ 0 the recursion cancels, but its terms
/// are then as small as φ).
template <class T, bool K44>
UDVR_CPU_GPU UDVR_INLINE void remainderTailFrom(const BoxSplineFastScaled<T, K44>& b, T z, T cdf,
                                                T pdf, T out[3]) {
    using S = lanes::ScalarOf<T>;
    using lanes::fma;
    const T m1 = fma(z, cdf, pdf);
    const T m2 = fma(z, m1, cdf) * S(0.5);
    const T m3 = fma(z, m2, m1) * S(1.0 / 3.0);
    const T m4 = fma(z, m3, m2) * S(0.25);
    const T z2 = z * z;
    T e2, e3, e4;
    if constexpr (K44) {
        e2 = -z * fma(z2, fma(z2, b.c2, b.c1), b.c0);  // −(k4·He1 + k6·He3 + k44·He5)
        e3 = fma(z2, fma(z2, b.d2, b.d1), b.d0);       // k4 + k6·He2 + k44·He4
        e4 = -z * fma(z2, b.f1, b.f0);                 // −(k6·He1 + k44·He3)
    } else {                                           // k44 = 0: c2 = d2 = f1 = 0
        e2 = -z * fma(z2, b.c1, b.c0);
        e3 = fma(z2, b.d1, b.d0);
        e4 = -z * b.f0;
    }
    out[0] = fma(e2, pdf, m2);
    out[1] = fma(e3, pdf, m3);
    out[2] = fma(e4, pdf, fma(b.k4, cdf, m4));
}
/// remainderTailFrom at z with Φ, φ from normalAt.
template <class T>
UDVR_CPU_GPU UDVR_INLINE void remainderTail(const BoxSplineFastScaled<T>& b, T z, T out[3]) {
    const NormalAt<T> n = normalOf(z);
    remainderTailFrom(b, z, n.cdf, n.pdf, out);
}

/// Level one (below) right of the pair's support: the closed form Σ_i z^{j−i}/(j−i)! · w_i.
template <class T, bool K44>
UDVR_CPU_GPU UDVR_INLINE void levelOneClosed(const BoxSplineFastScaled<T, K44>& b, T z, T out[3]) {
    using S = lanes::ScalarOf<T>;
    using lanes::fma;
    const T z2 = z * z * S(0.5);
    out[0] = z + b.w1;
    out[1] = fma(z, b.w1, z2 + b.w2);
    out[2] = fma(z2, fma(z, lanes::splat<T>(S(1.0 / 3.0)), b.w1), fma(z, b.w2, b.w3));
}
/// E[(σz + h2·U2 + R)_+^j]/(j!·σ^j), j = 1, 2, 3 (level one of the tree) from remainderTail's
/// values a at z + h2/σ and c at z: their divided difference over h2/σ, or right of the node's
/// support (z ≥ cutoff) levelOneClosed (no digits lost to z ≫ h2/σ).
template <class T, bool K44>
UDVR_CPU_GPU UDVR_INLINE void levelOneFrom(const BoxSplineFastScaled<T, K44>& b, T z, const T a[3],
                                           const T c[3], lanes::ScalarOf<T> cutoff, T out[3]) {
    for (int j = 0; j < 3; ++j) out[j] = (a[j] - c[j]) * b.invH2;
    const auto right = z >= lanes::splat<T>(cutoff);
    if (!lanes::anyOf(right)) return;
    T closed[3];
    levelOneClosed(b, z, closed);
    for (int j = 0; j < 3; ++j) out[j] = select(right, closed[j], out[j]);
}
/// levelOneFrom with the remainder evaluated at both nodes, cut off at kBoxSplineCutoffSigmas.
template <class T>
UDVR_CPU_GPU UDVR_INLINE void levelOneTail(const BoxSplineFastScaled<T>& b, T z, T out[3]) {
    using S = lanes::ScalarOf<T>;
    T a[3], c[3];
    remainderTail(b, z + b.h2, a);
    remainderTail(b, z, c);
    levelOneFrom(b, z, a, c, S(kBoxSplineCutoffSigmas), out);
}
}  // namespace detail

/// E[(t + X − center)_+^d]/σ^d, d = 0, 1, 2, at z = t/σ, for BoxSplineFast: the divided
/// difference over h1 of level one times d!. Every difference divides by the widest remaining box
/// and differences values at most ~(h1 + h2 + 8σ)^{d+1} (σ ≤ 0.71·h2: the remainder's boxes are
/// each ≤ h2), so float keeps ~1e−6 of T's scale.
template <class T>
UDVR_CPU_GPU UDVR_INLINE void boxSplineFastTail(const detail::BoxSplineFastScaled<T>& b, T z,
                                                T out[3]) {
    using S = lanes::ScalarOf<T>;
    T a[3], c[3];
    detail::levelOneTail(b, z + b.h1, a);
    detail::levelOneTail(b, z, c);
    out[0] = (a[0] - c[0]) * b.invH1;
    out[1] = (a[1] - c[1]) * b.invH1;
    out[2] = (a[2] - c[2]) * (b.invH1 * S(2));
}

namespace detail {
/// The change of the TF's polynomials at break k (piece k re-expanded about u_k, subtracted
/// from piece k+1): Δ_d of (x − u_k)_+^d, d = 0, 1, 2, per channel; false where all are 0.
template <class S, class Tf>
UDVR_CPU_GPU UDVR_INLINE bool tfBreakChange(const Tf& tf, int k, S da[4], S db[4], S dc[4]) {
    const S len = tf.at(kTfBound, k) - tf.at(kTfOrigin, k);
    bool any = false;
    for (int ch = 0; ch < 4; ++ch) {
        const S pa = tf.at(kTfA + ch, k), pb = tf.at(kTfB + ch, k), pc = tf.at(kTfC + ch, k);
        da[ch] = tf.at(kTfA + ch, k + 1) - (pa + len * (pb + len * pc));
        db[ch] = tf.at(kTfB + ch, k + 1) - (pb + S(2) * len * pc);
        dc[ch] = tf.at(kTfC + ch, k + 1) - pc;
        any = any || da[ch] != S(0) || db[ch] != S(0) || dc[ch] != S(0);
    }
    return any;
}

/// The four nodes of break k in σ units: z, z + h2, z + h1, z + h1 + h2 with z = (center −
/// u_k)/σ (levels: node 0, 1 the lower pair, 2, 3 the upper one).
template <class T, bool K44>
UDVR_CPU_GPU UDVR_INLINE void breakNodes(const BoxSplineFastScaled<T, K44>& sc, T center, T u,
                                         T z[4]) {
    z[0] = (center - u) * sc.invSigma;
    z[1] = z[0] + sc.h2;
    z[2] = z[0] + sc.h1;
    z[3] = z[2] + sc.h2;
}

/// out += Σ_d Δ_d·σ^d·T(u, d) in the lanes `on` for the break whose nodes are z (breakNodes):
/// level one at the upper (z + h1) pair — its closed form where `upperRight` (every lane right
/// of it), else from nodes 2 and 3 — and at the lower (z) pair from nodes 0 and 1 (never right
/// of them), then their divided difference over h1 (q1 = σ·invH1, q2 = 2σ²·invH1: σ^d and d!
/// folded in).
/// node(i, r) writes remainderTailFrom at node i to r.
template <class T, bool K44, class S, class Node>
UDVR_CPU_GPU UDVR_INLINE void addBreak(const BoxSplineFastScaled<T, K44>& sc, const T z[4],
                                       bool upperRight, const Node& node, lanes::MaskOf<T> on,
                                       const S da[4], const S db[4], const S dc[4], T q1, T q2,
                                       T out[4]) {
    T r[4][3], upper[3], lower[3];
    if (upperRight) {
        levelOneClosed(sc, z[2], upper);
    } else {
        node(2, r[2]);
        node(3, r[3]);
        levelOneFrom(sc, z[2], r[3], r[2], S(kBoxSplineNearSigmas), upper);
    }
    node(0, r[0]);
    node(1, r[1]);
    // The lower pair needs no closed form: in the lanes `on` the break lies right of the
    // support's left end, so z < r1/(2σ) ≤ √18 ≈ 4.24 (the remainder's ≤ 6 widths sum to r1 ≤
    // √(6·12σ²)), and z ≤ 3·h2 (σ ≤ h2/√2): the difference loses no digits. Other lanes are
    // dropped below (measured on the tangle frame: z < 4.238 in all 9.7·10⁷ lanes `on`).
    for (int j = 0; j < 3; ++j) lower[j] = (r[1][j] - r[0][j]) * sc.invH2;
    // T(u, d)·σ^d for d = 0, 1, 2 (d! folded into q2), 0 outside `on`.
    const T t0 = select(on, (upper[0] - lower[0]) * sc.invH1, T{});
    const T t1 = select(on, (upper[1] - lower[1]) * q1, T{});
    const T t2 = select(on, (upper[2] - lower[2]) * q2, T{});
    for (int ch = 0; ch < 4; ++ch)
        out[ch] = fma(lanes::splat<T>(dc[ch]), t2,
                      fma(lanes::splat<T>(db[ch]), t1, fma(lanes::splat<T>(da[ch]), t0, out[ch])));
}

/// The breaks kFirst … kLast − 1 of expectedTfUniformFast, one value of T at a time: Φ and φ
/// only at nodes within kBoxSplineNearSigmas, and the upper pair's nodes not at all where it is
/// right of them (its closed form; a quarter of the tangle's breaks).
template <class T, class Tf>
UDVR_CPU_GPU UDVR_INLINE void uniformFastBreaks(const Tf& tf, const BoxSplineFast<T>& b,
                                                const BoxSplineFastScaled<T, false>& sc,
                                                lanes::MaskOf<T> spread, lanes::IntOf<T> kl,
                                                lanes::IntOf<T> kh, int kFirst, int kLast, T q1,
                                                T q2, T out[4]) {
    using S = lanes::ScalarOf<T>;
    for (int k = kFirst; k < kLast; ++k) {
        S da[4], db[4], dc[4];
        if (!tfBreakChange<S>(tf, k, da, db, dc)) continue;
        const auto on = spread & (kl <= k) & (kh > k);
        if (!lanes::anyOf(on)) continue;
        T z[4];
        breakNodes(sc, b.center, lanes::splat<T>(tf.at(kTfBound, k)), z);
        const auto node = [&](int i, T r[3]) {
            T cdf = z[i] >= S(0) ? S(1) : S(0), pdf = S(0);
            if (lanes::abs(z[i]) < S(kBoxSplineNearSigmas)) {
                const NormalAt<T> n = normalOf(z[i]);
                cdf = n.cdf;
                pdf = n.pdf;
            }
            remainderTailFrom(sc, z[i], cdf, pdf, r);
        };
        addBreak(sc, z, z[2] >= S(kBoxSplineNearSigmas), node, on, da, db, dc, q1, q2, out);
    }
}

/// uniformFastBreaks on lanes, a block of up to kBlock breaks at a time: first the nodes within
/// kBoxSplineNearSigmas of every break of the block are packed (lanes::compressStore), then Φ
/// and φ are evaluated on full vectors of them (normalCdfPdfNear), then unpacked per node, the
/// others taking the one-sided limits. On the tangle 36 % of a break's 16 × 4 lane-nodes need
/// Φ: the others are dead lanes, lanes whose support the break is outside, or ≥ 5σ away. As
/// there, the upper pair takes its closed form where every lane is right of it.
template <class Tf>
UDVR_INLINE void uniformFastBreaks(const Tf& tf, const BoxSplineFast<lanes::Vf>& b,
                                   const BoxSplineFastScaled<lanes::Vf, false>& sc,
                                   lanes::Mask spread, lanes::Vi kl, lanes::Vi kh, int kFirst,
                                   int kLast, lanes::Vf q1, lanes::Vf q2, lanes::Vf out[4]) {
    using lanes::Vf;
    constexpr int kBlock = 4;  // breaks (4 and 8 measured alike; 16 slower)
    constexpr int kW = lanes::kWidth;
    constexpr int kSlots = kBlock * 4 * kW + kW;  // a vector past the last packed node
    struct Break {
        lanes::Mask on, near[4];
        int at[4];  // the first packed slot of each node
        float da[4], db[4], dc[4];
        float u;
    };
    Break block[kBlock];
    alignas(64) float zs[kSlots], cdfs[kSlots], pdfs[kSlots];
    const Vf near = lanes::splat<Vf>(static_cast<float>(kBoxSplineNearSigmas));
    for (int k = kFirst; k < kLast;) {
        int n = 0, packed = 0;
        for (; k < kLast && n < kBlock; ++k) {
            Break& e = block[n];
            if (!tfBreakChange<float>(tf, k, e.da, e.db, e.dc)) continue;
            e.on = spread & (kl <= k) & (kh > k);
            if (!lanes::anyOf(e.on)) continue;
            e.u = tf.at(kTfBound, k);
            Vf z[4];
            breakNodes(sc, b.center, lanes::splat<Vf>(e.u), z);
            for (int i = 0; i < 4; ++i) {
                e.near[i] = e.on & (lanes::abs(z[i]) < near);
                e.at[i] = packed;
                packed += lanes::compressStore(zs + packed, z[i], e.near[i]);
            }
            ++n;
        }
        lanes::store(zs + packed, Vf{});  // the last vector's unused slots: finite
        for (int i = 0; i < packed; i += kW) {
            Vf cdf, pdf;
            normalCdfPdfNear(lanes::load(zs + i), cdf, pdf);
            lanes::store(cdfs + i, cdf);
            lanes::store(pdfs + i, pdf);
        }
        for (int j = 0; j < n; ++j) {
            const Break& e = block[j];
            Vf z[4];
            breakNodes(sc, b.center, lanes::splat<Vf>(e.u), z);
            const auto node = [&](int i, Vf r[3]) {
                const Vf side = lanes::select(z[i] >= 0.f, lanes::splat<Vf>(1.f), Vf{});
                const Vf cdf = lanes::expandLoad(cdfs + e.at[i], e.near[i], side);
                const Vf pdf = lanes::expandLoad(pdfs + e.at[i], e.near[i], Vf{});
                remainderTailFrom(sc, z[i], cdf, pdf, r);
            };
            addBreak(sc, z, lanes::noneOf(e.on & (z[2] < near)), node, e.on, e.da, e.db, e.dc, q1,
                     q2, out);
        }
    }
}
}  // namespace detail

/// E[TF(X)] for the fast form of the box spline (issue 12), in the `live` lanes, against the
/// exact TF pieces: as expectedTfUniformSum, TF = p_0 + Σ_{breaks u in the support}
/// Σ_d Δ_d·(x − u)_+^d with p_0 the support's first piece, so E[TF(X)] = E[p_0(X)] (exact mean
/// and variance) + Σ_u Δ_d·T(center − u, d) (boxSplineFastTail's tree, its remainder cut off at
/// kBoxSplineNearSigmas). Sums of total width ≤ `point` are the point mass TF(mean). The
/// approximation's error is measured in docs/models.md.
template <class T, class Tf>
UDVR_CPU_GPU UDVR_INLINE void expectedTfUniformFast(const Tf& tf, const BoxSplineFast<T>& b,
                                                    lanes::ScalarOf<T> point, lanes::MaskOf<T> live,
                                                    T out[4]) {
    using S = lanes::ScalarOf<T>;
    using detail::fma;
    const T hi = b.lo + b.total;
    const T mean = fma(b.total, lanes::splat<T>(S(0.5)), b.lo);
    const auto kl = tf.pieceOf(b.lo);
    const auto kh = tf.pieceOf(hi);
    {
        const T et = mean - tf.at(kTfOrigin, kl);
        const T et2 = fma(et, et, b.variance);
        for (int ch = 0; ch < 4; ++ch)
            out[ch] =
                fma(tf.at(kTfC + ch, kl), et2, fma(tf.at(kTfB + ch, kl), et, tf.at(kTfA + ch, kl)));
    }
    const auto pointMass = live & (b.total <= point);
    if (lanes::anyOf(pointMass)) {
        T v[4];
        tfAt<T>(tf, mean, v);
        for (int ch = 0; ch < 4; ++ch) out[ch] = detail::select(pointMass, v[ch], out[ch]);
    }
    const auto spread = live & !pointMass & (kl != kh);
    if (!lanes::anyOf(spread)) return;
    const detail::BoxSplineFastScaled<T, false> scaled(b);  // no κ4² term (measured better)
    // T's divided difference over h1 (1/h1 in σ units) times σ^d·d!: the break's Δ_d multiply it.
    const T q1 = scaled.invH1 * b.sigma, q2 = q1 * b.sigma * S(2);
    const int kFirst = detail::lowestOf(kl, spread), kLast = detail::highestOf(kh, spread);
    detail::uniformFastBreaks(tf, b, scaled, spread, kl, kh, kFirst, kLast, q1, q2, out);
}

}  // namespace udvr
