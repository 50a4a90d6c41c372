#pragma once
// Exact piecewise-polynomial form of a 1D transfer function (SPEC §4) for the per-sample hot path.
//
// The TF is piecewise linear in α and in c between control points, so on each interval between
// consecutive *distinct* breakpoints u_0 < … < u_{N-1} (the union of colour and opacity x) the
// four channels (α·r, α·g, α·b, α) are polynomials of degree ≤ 2. A TfTable stores, per piece,
// those polynomials in the local coordinate t = x − origin, plus the antiderivative P(x) = ∫ TF
// at the piece origin (a prefix sum over pieces), plus a uniform bucket grid that finds the piece
// of a value in O(1). Everything is exact up to double rounding: no resampling error, steps
// (two control points at one x) are honoured exactly (right-continuous), and outside
// [u_0, u_{N-1}] the TF is the clamped constant.
//
// Pieces: 0 = (−∞, u_0) (constant), k = 1…N−1 = [u_{k−1}, u_k), N = [u_{N−1}, ∞) (constant).
// TfTable is a plain view (sizes and raw pointers) into a TfTableStorage that outlives it.
#include <cstddef>
#include <vector>

#include "udvr/classify/transfer_function.h"
#include "udvr/util/check.h"

namespace udvr {

/// One piece of the TF: channel ch = (α·r, α·g, α·b, α) is a[ch] + b[ch]·t + c[ch]·t²,
/// t = x − origin (data units); cum[ch] = ∫_{u_0}^{origin} TF_ch (data units × channel).
struct TfPiece {
    double origin;
    double a[4], b[4], c[4];
    double cum[4];
};

/// Read-only view of the exact TF pieces; device-copyable.
struct TfTable {
    int breakCount = 0;               // N ≥ 1 distinct breakpoints
    const double* breaks = nullptr;   // u_0 < … < u_{N−1}
    const TfPiece* pieces = nullptr;  // N + 1 pieces
    int bucketCount = 0;              // uniform buckets over [u_0, u_{N−1}] (0 when N = 1)
    double bucketInvWidth = 0.0;      // buckets per data unit
    const int* buckets = nullptr;     // piece holding each bucket's left end (1 … N−1)

    /// Index of the piece holding x (0 … N); O(1) on average.
    UDVR_CPU_GPU int pieceOf(double x) const {
        if (!(x >= breaks[0])) return 0;  // also NaN → left constant
        if (x >= breaks[breakCount - 1]) return breakCount;
        int bi = static_cast<int>((x - breaks[0]) * bucketInvWidth);
        bi = bi < 0 ? 0 : (bi >= bucketCount ? bucketCount - 1 : bi);
        int k = buckets[bi];
        while (x >= breaks[k]) ++k;              // k ≤ N−1 since x < u_{N−1}
        while (k > 1 && x < breaks[k - 1]) --k;  // guards rounding of the bucket index
        return k;
    }
    /// TF channels (α·r, α·g, α·b, α) at x, exact.
    UDVR_CPU_GPU void eval(double x, double out[4]) const { evalPiece(pieceOf(x), x, out); }
    /// Same, on a known piece.
    UDVR_CPU_GPU void evalPiece(int k, double x, double out[4]) const {
        const TfPiece& p = pieces[k];
        const double t = x - p.origin;
        for (int ch = 0; ch < 4; ++ch) out[ch] = p.a[ch] + t * (p.b[ch] + t * p.c[ch]);
    }
    /// ∫_{lo}^{hi} TF over a sub-interval of one piece (lo ≤ hi inside piece k).
    UDVR_CPU_GPU void integratePiece(int k, double lo, double hi, double out[4]) const {
        const TfPiece& p = pieces[k];
        const double tl = lo - p.origin, th = hi - p.origin, w = hi - lo;
        const double s1 = 0.5 * (tl + th), s2 = (tl * tl + tl * th + th * th) * (1.0 / 3.0);
        for (int ch = 0; ch < 4; ++ch) out[ch] = w * (p.a[ch] + p.b[ch] * s1 + p.c[ch] * s2);
    }
    /// Mean of TF over [lo, hi] given the pieces kl, kh of lo and hi; TF(hi) when hi ≤ lo.
    /// Exact; O(1): partial pieces at both ends plus the prefix-sum difference of full pieces
    /// between them, so tiny intervals never suffer cancellation.
    UDVR_CPU_GPU void meanOver(double lo, double hi, int kl, int kh, double out[4]) const {
        if (!(hi > lo)) {
            evalPiece(kh, hi, out);
            return;
        }
        const TfPiece& pl = pieces[kl];
        const TfPiece& ph = pieces[kh];
        if (kl == kh) {
            const double tl = lo - pl.origin, th = hi - pl.origin;
            const double s1 = 0.5 * (tl + th), s2 = (tl * tl + tl * th + th * th) * (1.0 / 3.0);
            for (int ch = 0; ch < 4; ++ch) out[ch] = pl.a[ch] + pl.b[ch] * s1 + pl.c[ch] * s2;
            return;
        }
        double left[4], right[4];
        integratePiece(kl, lo, breaks[kl], left);  // piece kl ends at u_kl
        integratePiece(kh, ph.origin, hi, right);  // piece kh starts at u_{kh−1} = its origin
        const TfPiece& pn = pieces[kl + 1];  // full pieces kl+1 … kh−1 span [u_kl, u_{kh−1}]
        const double inv = 1.0 / (hi - lo);
        for (int ch = 0; ch < 4; ++ch)
            out[ch] = (left[ch] + (ph.cum[ch] - pn.cum[ch]) + right[ch]) * inv;
    }
    /// Mean of TF over [lo, hi] (finds the pieces).
    UDVR_CPU_GPU void meanOver(double lo, double hi, double out[4]) const {
        meanOver(lo, hi, pieceOf(lo), pieceOf(hi), out);
    }
};

/// Owns the arrays a TfTable views. Non-copyable views stay valid while this lives.
class TfTableStorage {
  public:
    /// Build from a validated TF; `bucketCount` uniform buckets over the breakpoint range.
    explicit TfTableStorage(const TransferFunction1D& tf, int bucketCount = 4096);
    TfTableStorage(const TfTableStorage&) = delete;
    TfTableStorage& operator=(const TfTableStorage&) = delete;
    /// The device-copyable view.
    const TfTable& table() const { return table_; }

  private:
    std::vector<double> breaks_;
    std::vector<TfPiece> pieces_;
    std::vector<int> buckets_;
    TfTable table_;
};

}  // namespace udvr
