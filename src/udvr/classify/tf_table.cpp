#include "udvr/classify/tf_table.h"

#include <algorithm>
#include <array>

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

// (α, r, g, b) just left of x and at x (right-continuous).
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

// Constant piece with value s.
TfPiece constantPiece(double origin, const Sides& s) {
    TfPiece p{};
    p.origin = origin;
    for (int ch = 0; ch < 3; ++ch) p.a[ch] = s.alpha * s.rgb[ch];
    p.a[3] = s.alpha;
    return p;
}

}  // namespace

TfTableStorage::TfTableStorage(const TransferFunction1D& tf, int bucketCount) {
    tf.validate();
    breaks_.reserve(tf.colorX.size() + tf.opacityX.size());
    breaks_.insert(breaks_.end(), tf.colorX.begin(), tf.colorX.end());
    breaks_.insert(breaks_.end(), tf.opacityX.begin(), tf.opacityX.end());
    std::sort(breaks_.begin(), breaks_.end());
    breaks_.erase(std::unique(breaks_.begin(), breaks_.end()), breaks_.end());
    const int n = static_cast<int>(breaks_.size());

    pieces_.resize(static_cast<std::size_t>(n) + 1);
    pieces_[0] = constantPiece(breaks_[0], leftSide(tf, breaks_[0]));
    for (int k = 1; k < n; ++k) {
        // On [u_{k−1}, u_k) α and c are linear: α = α0 + dα·t/L, c = c0 + dc·t/L, so
        // α·c = α0c0 + (α0·dc + c0·dα)/L·t + dα·dc/L²·t².
        const double x0 = breaks_[k - 1], x1 = breaks_[k], len = x1 - x0;
        const Sides s0 = rightSide(tf, x0), s1 = leftSide(tf, x1);
        TfPiece& p = pieces_[k];
        p = TfPiece{};
        p.origin = x0;
        const double da = s1.alpha - s0.alpha;
        for (int ch = 0; ch < 3; ++ch) {
            const double dc = s1.rgb[ch] - s0.rgb[ch];
            p.a[ch] = s0.alpha * s0.rgb[ch];
            p.b[ch] = (s0.alpha * dc + s0.rgb[ch] * da) / len;
            p.c[ch] = da * dc / (len * len);
        }
        p.a[3] = s0.alpha;
        p.b[3] = da / len;
        p.c[3] = 0.0;
    }
    pieces_[static_cast<std::size_t>(n)] =
        constantPiece(breaks_[static_cast<std::size_t>(n) - 1],
                      rightSide(tf, breaks_[static_cast<std::size_t>(n) - 1]));

    // Prefix sums of the exact integrals: cum of piece k+1 = cum of piece k + ∫ piece k.
    for (int ch = 0; ch < 4; ++ch) pieces_[0].cum[ch] = pieces_[1].cum[ch] = 0.0;  // P(u_0) = 0
    for (int k = 1; k < n; ++k) {
        TfPiece& p = pieces_[static_cast<std::size_t>(k)];
        const double len = breaks_[static_cast<std::size_t>(k)] - p.origin;
        for (int ch = 0; ch < 4; ++ch) {
            const double integral = len * (p.a[ch] + len * (p.b[ch] * 0.5 + len * p.c[ch] / 3.0));
            pieces_[static_cast<std::size_t>(k) + 1].cum[ch] = p.cum[ch] + integral;
        }
    }

    // Bucket grid: buckets_[i] = the piece holding the left end of bucket i.
    if (n > 1) {
        bucketCount = std::max(bucketCount, 1);
        const double lo = breaks_.front(), hi = breaks_.back();
        const double width = (hi - lo) / bucketCount;
        buckets_.resize(static_cast<std::size_t>(bucketCount));
        for (int i = 0; i < bucketCount; ++i) {
            const double x = lo + width * i;
            int k = static_cast<int>(std::upper_bound(breaks_.begin(), breaks_.end(), x) -
                                     breaks_.begin());
            buckets_[static_cast<std::size_t>(i)] = std::clamp(k, 1, n - 1);
        }
        table_.bucketCount = bucketCount;
        table_.bucketInvWidth = bucketCount / (hi - lo);
        table_.buckets = buckets_.data();
    }
    table_.breakCount = n;
    table_.breaks = breaks_.data();
    table_.pieces = pieces_.data();
}

}  // namespace udvr
