#include "udvr/classify/tf_pieces.h"

#include <algorithm>
#include <bit>
#include <cmath>

namespace udvr {
namespace {

// Value of the piecewise-linear (xs, v) just left of x (the limit from below); clamped. At a step
// (several points at x) the earliest of them is the left limit.
template <class Get>
double leftLimit(const std::vector<double>& xs, double x, Get v) {
    const std::size_t n = xs.size();
    if (x <= xs.front()) return v(0);
    if (x > xs.back()) return v(n - 1);
    const std::size_t i =
        static_cast<std::size_t>(std::lower_bound(xs.begin(), xs.end(), x) - xs.begin());
    if (xs[i] == x) return v(i);
    const double t = (x - xs[i - 1]) / (xs[i] - xs[i - 1]);
    return v(i - 1) + t * (v(i) - v(i - 1));
}

// α and (r, g, b) just left of x, or at x (right-continuous).
struct Sides {
    double alpha, rgb[3];
};
Sides leftSide(const TransferFunction1D& tf, double x) {
    Sides s{};
    s.alpha = leftLimit(tf.opacityX, x, [&](std::size_t i) { return tf.opacity[i]; });
    for (int ch = 0; ch < 3; ++ch)
        s.rgb[ch] = leftLimit(tf.colorX, x, [&](std::size_t i) { return tf.color[i][ch]; });
    return s;
}
Sides rightSide(const TransferFunction1D& tf, double x) {
    Sides s{};
    s.alpha = tf.opacityAt(x);
    const auto c = tf.colorAt(x);
    for (int ch = 0; ch < 3; ++ch) s.rgb[ch] = c[ch];
    return s;
}

// One piece in double about its origin.
struct Piece {
    double origin = 0.0;
    double a[4] = {}, b[4] = {}, c[4] = {}, cum[4] = {};
    double alpha0 = 0.0, alphaSlope = 0.0, color0[3] = {}, colorSlope[3] = {};

    // α and c linear from `s0` at the origin with slopes (s1 − s0)/len (len 0: constant).
    void setLines(const Sides& s0, const Sides& s1, double len) {
        alpha0 = s0.alpha;
        alphaSlope = len > 0.0 ? (s1.alpha - s0.alpha) / len : 0.0;
        for (int ch = 0; ch < 3; ++ch) {
            color0[ch] = s0.rgb[ch];
            colorSlope[ch] = len > 0.0 ? (s1.rgb[ch] - s0.rgb[ch]) / len : 0.0;
        }
        // α·c = α0c0 + (α0·sc + c0·sα)·t + sα·sc·t².
        for (int ch = 0; ch < 3; ++ch) {
            a[ch] = alpha0 * color0[ch];
            b[ch] = alpha0 * colorSlope[ch] + color0[ch] * alphaSlope;
            c[ch] = alphaSlope * colorSlope[ch];
        }
        a[3] = alpha0;
        b[3] = alphaSlope;
        c[3] = 0.0;
    }
    // The same polynomials about origin + d (exact re-expansion in double).
    Piece shifted(double d) const {
        Piece p = *this;
        p.origin = origin + d;
        for (int ch = 0; ch < 4; ++ch) {
            p.a[ch] = a[ch] + d * (b[ch] + d * c[ch]);
            p.b[ch] = b[ch] + 2.0 * d * c[ch];
        }
        p.alpha0 = alpha0 + d * alphaSlope;
        for (int ch = 0; ch < 3; ++ch) p.color0[ch] = color0[ch] + d * colorSlope[ch];
        return p;
    }
};

template <class Real>
void fillColumns(const std::vector<double>& breaks, const std::vector<Piece>& pieces, int stride,
                 std::vector<Real>& data) {
    const int n = static_cast<int>(breaks.size());
    data.assign(static_cast<std::size_t>(kTfColumns) * stride, Real(0));
    const auto col = [&](int f, int k) -> Real& {
        return data[static_cast<std::size_t>(f) * stride + k];
    };
    for (int k = 0; k < stride; ++k) {
        col(kTfBound, k) =
            k < n ? static_cast<Real>(breaks[k]) : std::numeric_limits<Real>::infinity();
        const Piece& exact = pieces[static_cast<std::size_t>(std::min(k, n))];
        // Float: re-expand about the rounded origin, so the float piece is the same polynomial.
        const Piece p =
            exact.shifted(static_cast<double>(static_cast<Real>(exact.origin)) - exact.origin);
        col(kTfOrigin, k) = static_cast<Real>(p.origin);
        for (int ch = 0; ch < 4; ++ch) {
            col(kTfA + ch, k) = static_cast<Real>(p.a[ch]);
            col(kTfB + ch, k) = static_cast<Real>(p.b[ch]);
            col(kTfC + ch, k) = static_cast<Real>(p.c[ch]);
            const Real hi = static_cast<Real>(exact.cum[ch]);
            col(kTfCum + ch, k) = hi;
            col(kTfCumLo + ch, k) = static_cast<Real>(exact.cum[ch] - static_cast<double>(hi));
        }
        bool zero = true;
        for (int ch = 0; ch < 4; ++ch)
            zero = zero && exact.a[ch] == 0.0 && exact.b[ch] == 0.0 && exact.c[ch] == 0.0;
        col(kTfZero, k) = zero ? Real(1) : Real(0);
        col(kTfAlpha0, k) = static_cast<Real>(p.alpha0);
        col(kTfAlphaSlope, k) = static_cast<Real>(p.alphaSlope);
        for (int ch = 0; ch < 3; ++ch) {
            col(kTfColor0 + ch, k) = static_cast<Real>(p.color0[ch]);
            col(kTfColorSlope + ch, k) = static_cast<Real>(p.colorSlope[ch]);
        }
    }
}

// Every channel 0 on the whole piece.
bool isZero(const Piece& p) {
    for (int ch = 0; ch < 4; ++ch)
        if (p.a[ch] != 0.0 || p.b[ch] != 0.0 || p.c[ch] != 0.0) return false;
    return true;
}

// Drops each breakpoint between two zero pieces (α = 0 on both sides: colour points where
// nothing is visible, and the clamped ends), so the TF is the same function with fewer pieces:
// every search and Gaussian sweep walks fewer bounds, and small TFs fit smaller lookup tables.
// The merged piece keeps the left one's origin (its polynomials are 0 about any origin); at least
// one breakpoint stays. cum (computed after) is unchanged: the integral over zero pieces is 0.
void mergeZeroRuns(std::vector<double>& breaks, std::vector<Piece>& pieces) {
    std::size_t kept = 0;  // breaks[0 … kept) and pieces[0 … kept] are the output so far
    for (std::size_t k = 0; k < breaks.size(); ++k) {
        const bool redundant = isZero(pieces[kept]) && isZero(pieces[k + 1]);
        if (redundant && !(kept == 0 && k + 1 == breaks.size())) continue;
        breaks[kept] = breaks[k];
        pieces[++kept] = pieces[k + 1];
    }
    breaks.resize(kept);
    pieces.resize(kept + 1);
}

}  // namespace

TfPiecesStorage::TfPiecesStorage(const TransferFunction1D& tf, int bucketCount) {
    tf.validate();
    std::vector<double> breaks;
    breaks.insert(breaks.end(), tf.colorX.begin(), tf.colorX.end());
    breaks.insert(breaks.end(), tf.opacityX.begin(), tf.opacityX.end());
    std::sort(breaks.begin(), breaks.end());
    breaks.erase(std::unique(breaks.begin(), breaks.end()), breaks.end());
    const int breakCount = static_cast<int>(breaks.size());

    std::vector<Piece> pieces(static_cast<std::size_t>(breakCount) + 1);
    pieces[0].origin = breaks[0];
    const Sides first = leftSide(tf, breaks[0]);
    pieces[0].setLines(first, first, 0.0);
    for (int k = 1; k < breakCount; ++k) {
        Piece& p = pieces[static_cast<std::size_t>(k)];
        const double x0 = breaks[k - 1], x1 = breaks[k];
        p.origin = x0;
        p.setLines(rightSide(tf, x0), leftSide(tf, x1), x1 - x0);
    }
    Piece& lastPiece = pieces[static_cast<std::size_t>(breakCount)];
    lastPiece.origin = breaks[static_cast<std::size_t>(breakCount) - 1];
    const Sides last = rightSide(tf, lastPiece.origin);
    lastPiece.setLines(last, last, 0.0);
    mergeZeroRuns(breaks, pieces);
    const int n = static_cast<int>(breaks.size());
    // Prefix sums of the exact integrals: cum of piece k+1 = cum of piece k + ∫ piece k.
    for (int k = 1; k < n; ++k) {
        const Piece& p = pieces[static_cast<std::size_t>(k)];
        const double len = breaks[static_cast<std::size_t>(k)] - p.origin;
        for (int ch = 0; ch < 4; ++ch)
            pieces[static_cast<std::size_t>(k) + 1].cum[ch] =
                p.cum[ch] + len * (p.a[ch] + len * (p.b[ch] * 0.5 + len * p.c[ch] / 3.0));
    }

    // Columns long enough for the binary search (k + step − 1 < stride) and for 32-entry
    // register permutes on AVX-512 when the TF has at most 31 breakpoints.
    int stride = 32;
    while (stride < 2 * static_cast<int>(std::bit_floor(static_cast<unsigned>(n))) ||
           stride < n + 1)
        stride *= 2;
    fillColumns(breaks, pieces, stride, exactData_);
    fillColumns(breaks, pieces, stride, fastData_);

    // Bucket grid: buckets_[i] = the piece holding the left end of bucket i.
    double narrowest = std::numeric_limits<double>::infinity();
    for (int k = 1; k < n; ++k) narrowest = std::min(narrowest, breaks[k] - breaks[k - 1]);
    if (n > 1) {
        bucketCount = std::max(bucketCount, 1);
        const double lo = breaks.front(), hi = breaks.back();
        const double width = (hi - lo) / bucketCount;
        buckets_.resize(static_cast<std::size_t>(bucketCount));
        for (int i = 0; i < bucketCount; ++i) {
            const double x = lo + width * i;
            const int k = static_cast<int>(std::upper_bound(breaks.begin(), breaks.end(), x) -
                                           breaks.begin());
            buckets_[static_cast<std::size_t>(i)] = std::clamp(k, 1, n - 1);
        }
        exact_.bucketCount = fast_.bucketCount = bucketCount;
        exact_.bucketInvWidth = bucketCount / (hi - lo);
        fast_.bucketInvWidth = static_cast<float>(exact_.bucketInvWidth);
        exact_.buckets = fast_.buckets = buckets_.data();
    }
    exact_.breakCount = fast_.breakCount = n;
    exact_.stride = fast_.stride = stride;
    exact_.data = exactData_.data();
    fast_.data = fastData_.data();
    exact_.narrowestPiece = narrowest;
    fast_.narrowestPiece = static_cast<float>(narrowest);
}

}  // namespace udvr
