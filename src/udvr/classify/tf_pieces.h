#pragma once
// The transfer function as classification sees it (SPEC §4): one device-copyable type of exact
// pieces over a real type (double for the exact path, float for the batched and GPU paths).
//
// The TF is piecewise linear in α and in c between control points, so between consecutive
// *distinct* breakpoints u_0 < … < u_{N−1} (the union of colour and opacity x) α and c are
// linear and the four premultiplied channels (α·r, α·g, α·b, α) are polynomials of degree ≤ 2.
// Pieces: 0 = (−∞, u_0) (constant), k = 1 … N−1 = [u_{k−1}, u_k), N = [u_{N−1}, ∞) (constant):
// piece k of x is the number of breakpoints ≤ x (NaN: 0). Steps (two control points at one x)
// are honoured exactly (right-continuous) and outside [u_0, u_{N−1}] the TF is clamped.
//
// Per piece the view holds, as columns of one array (column f of piece k at data[f·stride + k],
// so a lane vector reads a column with one permute or gather):
//   bound        u_k (+inf from k = N on)
//   origin       the piece's left end (u_{k−1}; u_0 for piece 0), data units
//   a, b, c      channel ch = a + b·t + c·t², t = x − origin
//   cum, cumLo   ∫_{u_0}^{origin} TF_ch as the pair cum + cumLo (cumLo = 0 in double): a
//                difference of two prefix sums then keeps its digits when the sums are large
//   alpha0, alphaSlope, color0, colorSlope   α and c as lines a0 + s·t (TF(x) = (α·c, α))
//   zero         1 on pieces where the TF is 0 (integrals over them can be skipped)
// In float the origin is rounded first and the coefficients re-expanded about the rounded
// origin in double, so float pieces are the exact pieces up to the rounding of the coefficients.
#include <cstddef>
#include <limits>
#include <vector>

#include "udvr/classify/transfer_function.h"
#include "udvr/util/check.h"
#include "udvr/util/lanes.h"

namespace udvr {

/// Columns of TfPieces::data.
enum TfColumn : int {
    kTfBound = 0,
    kTfOrigin = 1,
    kTfA = 2,       // 4 columns, one per channel (α·r, α·g, α·b, α)
    kTfB = 6,       // 4
    kTfC = 10,      // 4
    kTfCum = 14,    // 4
    kTfCumLo = 18,  // 4
    kTfAlpha0 = 22,
    kTfAlphaSlope = 23,
    kTfColor0 = 24,      // 3
    kTfColorSlope = 27,  // 3
    kTfZero = 30,        // 1 where every channel is 0 on the whole piece (α = 0 there), else 0
    kTfColumns = 31,
};

/// Entries per column of a TF with at most 31 breakpoints (more: the next power of two).
inline constexpr int kTfSmall = 32;

/// Read-only view of the exact TF pieces over Real (double or float); device-copyable.
/// LookupSize > 0 promises fewer than LookupSize breakpoints (lane lookups by register permutes,
/// lanes::lookup); 0: any TF (gathers).
template <class Real, int LookupSize = 0>
struct TfPieces {
    static constexpr int kLookupSize = LookupSize;
    int breakCount = 0;  // N ≥ 1 distinct breakpoints
    int stride = 0;      // entries per column (≥ 32, ≥ 2·bit_floor(N), a multiple of 16)
    const Real* data = nullptr;    // kTfColumns columns
    int bucketCount = 0;           // uniform buckets over [u_0, u_{N−1}] (0 when N = 1)
    Real bucketInvWidth = 0;       // buckets per data unit
    const int* buckets = nullptr;  // piece holding each bucket's left end (1 … N−1)
    Real narrowestPiece = std::numeric_limits<Real>::infinity();  // min u_k − u_{k−1}

    /// Column f.
    UDVR_CPU_GPU const Real* column(int f) const {
        return data + static_cast<std::size_t>(f) * stride;
    }
    /// Column f at piece k (one scalar, or a lookup per lane).
    UDVR_CPU_GPU Real at(int f, int k) const { return column(f)[k]; }
    lanes::Vf at(int f, lanes::Vi k) const requires std::is_same_v<Real, float> {
        return lanes::lookup<LookupSize>(column(f), k);
    }
    /// The same view with lookups of a fixed table size (the TF must have fewer than Size
    /// breakpoints, so every piece index and every bound the search reads is below Size).
    template <int Size>
    TfPieces<Real, Size> sized() const {
        UDVR_DCHECK(breakCount < Size && stride >= Size);
        return TfPieces<Real, Size>{breakCount,     stride,  data,          bucketCount,
                                    bucketInvWidth, buckets, narrowestPiece};
    }

    /// The pieces first … first + count as a view of their own (count < 8: one 8-entry permute
    /// per lookup where lanes::kWindowLookups): piece first + i of this TF is piece i there, and
    /// pieceOf counts only the bounds u_first … u_{first+count−1}, so it is right for values
    /// whose piece here lies in [first, first + count] (the caller's promise). Lane lookups only
    /// (no buckets); they read 8 entries from first on AVX2 (first + 8 ≤ stride), 16 on
    /// AVX-512 (first + 16 ≤ stride there, where only the tests take windows).
    TfPieces<Real, 8> window(int first, int count) const {
        UDVR_DCHECK(first >= 0 && count >= 0 && count < 8 && first + 8 <= stride);
        return TfPieces<Real, 8>{count, stride, data + first, 0, Real(0), nullptr, narrowestPiece};
    }

    /// Piece of x (0 … N); O(1) on average: the bucket of x, then a short walk.
    UDVR_CPU_GPU int pieceOf(Real x) const {
        const Real* u = column(kTfBound);
        if (!(x >= u[0])) return 0;  // also NaN → left constant
        if (x >= u[breakCount - 1]) return breakCount;
        int bi = static_cast<int>((x - u[0]) * bucketInvWidth);
        bi = bi < 0 ? 0 : (bi >= bucketCount ? bucketCount - 1 : bi);
        int k = buckets[bi];
        while (x >= u[k]) ++k;              // k ≤ N−1 since x < u_{N−1}
        while (k > 1 && x < u[k - 1]) --k;  // guards rounding of the bucket index
        return k;
    }
    /// Piece of 16 values by binary search over the bounds (lookups; NaN: 0).
    lanes::Vi pieceOf(lanes::Vf x) const requires std::is_same_v<Real, float> {
        const float* u = column(kTfBound);
        if constexpr (LookupSize == 8 || LookupSize == 16) {
            // Few breakpoints: count those ≤ x with independent compares rather than a chain of
            // dependent lookups (AVX2, 64³ frames: quantile-range −16 %, the mean −9 %).
            lanes::Vi n = lanes::splati(0);
            for (int i = 0; i < breakCount; ++i) n -= x >= u[i];
            return n;
        }
        lanes::Vi k = lanes::splati(0);
        // k ← k + step where x ≥ u_{k+step−1}; k + step − 1 < stride since stride ≥ 2·bit_floor(N).
        for (int step = std::bit_floor(static_cast<unsigned>(breakCount)); step >= 1; step >>= 1) {
            const lanes::Vi cand = k + step;
            k = lanes::select(x >= lanes::lookup<LookupSize>(u, cand - 1), cand, k);
        }
        return lanes::min(k, lanes::splati(breakCount));  // x = +inf
    }
};

/// Owns the arrays a TfPieces<double> and a TfPieces<float> view; views stay valid while this
/// lives (non-copyable).
class TfPiecesStorage {
  public:
    /// Build from a TF (validated here); `bucketCount` uniform buckets over the breakpoints.
    explicit TfPiecesStorage(const TransferFunction1D& tf, int bucketCount = 4096);
    TfPiecesStorage(const TfPiecesStorage&) = delete;
    TfPiecesStorage& operator=(const TfPiecesStorage&) = delete;
    const TfPieces<double>& exact() const { return exact_; }
    const TfPieces<float>& fast() const { return fast_; }
    /// The view over Real.
    template <class Real>
    const TfPieces<Real>& view() const {
        if constexpr (std::is_same_v<Real, float>)
            return fast_;
        else
            return exact_;
    }

  private:
    std::vector<double> exactData_;
    std::vector<float> fastData_;
    std::vector<int> buckets_;
    TfPieces<double> exact_;
    TfPieces<float> fast_;
};

}  // namespace udvr
