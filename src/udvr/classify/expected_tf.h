#pragma once
// Expected transfer function E[TF(X)] = ∫ TF(x) pdf_X(x) dx (Athawale et al. 2021, Eq. 3; SPEC §4)
// for each reconstructed distribution, against the exact piecewise-polynomial TF of tf_table.h.
// Channels are (α·r, α·g, α·b, α); results before opacity correction. All closed forms, exact up
// to double rounding unless a comment says otherwise.
#include <cmath>
#include <new>

#include "udvr/classify/tf_table.h"
#include "udvr/reconstruct/box_spline.h"
#include "udvr/util/normal_cdf.h"

namespace udvr {

/// Beyond this many σ the Gaussian's mass (2·Φ(−7) ≈ 2.6e−12) is integrated against the
/// nearest TF piece inside (extended as a polynomial), so the cutoff error is < 1e−10.
inline constexpr double kGaussianCutoffSigmas = 7.0;

/// E[TF(X)], X ~ N(mean, σ²); σ = 0 is the point mass TF(mean). Per TF piece the polynomial
/// a + b·t + c·t² integrates against φ in closed form (Φ and φ terms).
UDVR_CPU_GPU inline void expectedTfGaussian(const TfTable& tf, double mean, double sigma,
                                            double out[4]) {
    if (!(sigma > 0.0)) {
        tf.eval(mean, out);
        return;
    }
    const int kl = tf.pieceOf(mean - kGaussianCutoffSigmas * sigma);
    const int kh = tf.pieceOf(mean + kGaussianCutoffSigmas * sigma);
    const double var = sigma * sigma;
    if (kl == kh) {  // one quadratic: E[p(X)] = p(μ) + c·σ²
        const TfPiece& p = tf.pieces[kl];
        const double t = mean - p.origin;
        for (int ch = 0; ch < 4; ++ch)
            out[ch] = p.a[ch] + t * (p.b[ch] + t * p.c[ch]) + p.c[ch] * var;
        return;
    }
    for (int ch = 0; ch < 4; ++ch) out[ch] = 0.0;
    // Φ, φ and z·φ at the left end z_a of piece k; the first piece starts at z_a = −∞.
    double cdfA = 0.0, pdfA = 0.0, zpdfA = 0.0;
    for (int k = kl; k <= kh; ++k) {
        double zb, cdfB, pdfB, zpdfB;
        if (k == kh) {
            zb = INFINITY;
            cdfB = 1.0;
            pdfB = zpdfB = 0.0;
        } else {
            zb = (tf.breaks[k] - mean) / sigma;
            const NormalCdfPdf n = normalCdfPdf(zb);  // |Φ error| < 1e−9 (util/normal_cdf.h)
            cdfB = n.cdf;
            pdfB = n.pdf;
            zpdfB = zb * pdfB;
        }
        // ∫ z^m φ over [za, zb]: m0 = ΔΦ, m1 = φ(za) − φ(zb), m2 = m0 + zaφ(za) − zbφ(zb).
        const double m0 = cdfB - cdfA, m1 = pdfA - pdfB, m2 = m0 + zpdfA - zpdfB;
        const TfPiece& p = tf.pieces[k];
        const double d = mean - p.origin;  // x − origin = d + σz
        for (int ch = 0; ch < 4; ++ch) {
            const double a = p.a[ch] + d * (p.b[ch] + d * p.c[ch]);
            const double b = (p.b[ch] + 2.0 * p.c[ch] * d) * sigma;
            const double c = p.c[ch] * var;
            out[ch] += a * m0 + b * m1 + c * m2;
        }
        cdfA = cdfB;
        pdfA = pdfB;
        zpdfA = zpdfB;
    }
}

/// E[TF(X)] for a sum of scaled uniforms (box spline), exact: TF = p_0 + Σ_{breaks u in the
/// support} Σ_d Δ_d·(x − u)_+^d with p_0 the quadratic of the support's first piece, so
/// E[TF(X)] = E[p_0(X)] (from mean and variance) + Σ Δ_d·E[(X − u)_+^d] (BoxSplineTail).
UDVR_CPU_GPU inline void expectedTfUniformSum(const TfTable& tf, const UniformSum& u,
                                              double out[4]) {
    if (u.n == 0) {
        tf.eval(u.shift, out);
        return;
    }
    const double lo = u.shift, hi = u.shift + u.total;
    const int kl = tf.pieceOf(lo), kh = tf.pieceOf(hi);
    const TfPiece& p0 = tf.pieces[kl];
    const double et = u.mean() - p0.origin, et2 = u.variance() + et * et;
    for (int ch = 0; ch < 4; ++ch) out[ch] = p0.a[ch] + p0.b[ch] * et + p0.c[ch] * et2;
    if (kl == kh) return;
    // Breaks where the TF's polynomial does not change (e.g. a colour point where α = 0 on both
    // sides, so α·c is 0 throughout) add nothing: skip them, and build the tail only if needed.
    alignas(BoxSplineTail) unsigned char storage[sizeof(BoxSplineTail)];
    const BoxSplineTail* tail = nullptr;
    for (int k = kl; k < kh; ++k) {
        const double x = tf.breaks[k];  // piece k ends, piece k+1 (origin x) starts
        const TfPiece& p = tf.pieces[k];
        const TfPiece& q = tf.pieces[k + 1];
        const double len = x - p.origin;
        double da[4], db[4], dc[4];
        bool any = false;
        for (int ch = 0; ch < 4; ++ch) {
            // Piece k re-expanded about x, subtracted from piece k+1.
            da[ch] = q.a[ch] - (p.a[ch] + len * (p.b[ch] + len * p.c[ch]));
            db[ch] = q.b[ch] - (p.b[ch] + 2.0 * len * p.c[ch]);
            dc[ch] = q.c[ch] - p.c[ch];
            any = any || da[ch] != 0.0 || db[ch] != 0.0 || dc[ch] != 0.0;
        }
        if (!any) continue;
        if (tail == nullptr) tail = new (storage) BoxSplineTail(u);
        double t[3];
        tail->at(u.shift - x, t);  // E[(X − x)_+^d]
        for (int ch = 0; ch < 4; ++ch) out[ch] += da[ch] * t[0] + db[ch] * t[1] + dc[ch] * t[2];
    }
}

/// Quantile-range expectation (Eq. 4) over quantiles j = j0+1 … j1, each weighted equally: the
/// mean over j of (mean of TF over [b_{j−1}, b_j]); a zero-width quantile contributes TF(b_j).
/// `boundary(j)` returns b_j (data units). O(j1 − j0): one piece search per boundary.
template <class Boundary>
UDVR_CPU_GPU inline void expectedTfQuantileRange(const TfTable& tf, const Boundary& boundary,
                                                 int j0, int j1, double out[4]) {
    for (int ch = 0; ch < 4; ++ch) out[ch] = 0.0;
    double bPrev = boundary(j0);
    int kPrev = tf.pieceOf(bPrev);
    for (int j = j0 + 1; j <= j1; ++j) {
        const double b = boundary(j);
        const int k = tf.pieceOf(b);
        double m[4];
        tf.meanOver(bPrev, b, kPrev, k, m);
        for (int ch = 0; ch < 4; ++ch) out[ch] += m[ch];
        bPrev = b;
        kPrev = k;
    }
    const double inv = 1.0 / (j1 - j0);
    for (int ch = 0; ch < 4; ++ch) out[ch] *= inv;
}

/// Quantile-mean expectation (Eq. 5): Σ_j TF(m_j)·p_j / Σ p_j over j = 1 … q, m_j the midpoint of
/// quantile j, p_j = (1/q)/w_j (densityWeights) or 1/q (mass weights, `quantile-mean-mass`).
/// With density weights, quantiles of width ≤ zeroWidth are point masses of infinite density:
/// they share all the weight equally (SPEC §4). One pass: both sums are kept.
template <class Boundary>
UDVR_CPU_GPU inline void expectedTfQuantileMean(const TfTable& tf, const Boundary& boundary, int q,
                                                bool densityWeights, double zeroWidth,
                                                double out[4]) {
    double sum[4] = {0, 0, 0, 0}, zeroSum[4] = {0, 0, 0, 0};
    double wsum = 0.0;
    int zeroCount = 0;
    double bPrev = boundary(0);
    for (int j = 1; j <= q; ++j) {
        const double b = boundary(j);
        const double w = b - bPrev;
        double v[4];
        tf.eval(0.5 * (bPrev + b), v);
        if (densityWeights && w <= zeroWidth) {
            ++zeroCount;
            for (int ch = 0; ch < 4; ++ch) zeroSum[ch] += v[ch];
        } else {
            const double weight = densityWeights ? 1.0 / w : 1.0;  // 1/q cancels
            for (int ch = 0; ch < 4; ++ch) sum[ch] += weight * v[ch];
            wsum += weight;
        }
        bPrev = b;
    }
    if (zeroCount > 0) {
        for (int ch = 0; ch < 4; ++ch) out[ch] = zeroSum[ch] / zeroCount;
    } else {
        for (int ch = 0; ch < 4; ++ch) out[ch] = sum[ch] / wsum;
    }
}

}  // namespace udvr
