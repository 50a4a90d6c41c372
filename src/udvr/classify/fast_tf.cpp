#include "udvr/classify/fast_tf.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace udvr {

FastTransferFunction::FastTransferFunction(const TransferFunction1D& tf) {
    tf.validate();
    std::vector<float> xs;
    for (double x : tf.colorX) xs.push_back(static_cast<float>(x));
    for (double x : tf.opacityX) xs.push_back(static_cast<float>(x));
    std::sort(xs.begin(), xs.end());
    xs.erase(std::unique(xs.begin(), xs.end()), xs.end());
    bounds_ = xs;
    const std::size_t nb = bounds_.size();
    regions_.resize(nb + 1);
    // Region coefficients from the reference evaluator at two interior points (a quarter and
    // half way), which lie on one linear piece because no breakpoint is strictly inside a
    // region; extrapolating to the left end gives the right-continuous value at a step even
    // where a control point's x is not exactly representable as a float.
    auto fill = [&](Region& g, double x0, double x1) {
        g.x0 = static_cast<float>(x0);
        const double xq = x0 + 0.25 * (x1 - x0), xm = x0 + 0.5 * (x1 - x0), h = xm - xq;
        const double aq = tf.opacityAt(xq), am = tf.opacityAt(xm);
        const auto cq = tf.colorAt(xq), cm = tf.colorAt(xm);
        const double as = (am - aq) / h;
        g.as = static_cast<float>(as);
        g.a0 = static_cast<float>(aq - as * (xq - x0));
        for (int ch = 0; ch < 3; ++ch) {
            const double cs = (cm[ch] - cq[ch]) / h;
            g.cs[ch] = static_cast<float>(cs);
            g.c0[ch] = static_cast<float>(cq[ch] - cs * (xq - x0));
        }
    };
    // Outside the control points everything is clamped (constant): evaluate well outside.
    auto fillConstant = [&](Region& g, double x0, double probe) {
        g.x0 = static_cast<float>(x0);
        const auto c = tf.colorAt(probe);
        g.a0 = static_cast<float>(tf.opacityAt(probe));
        g.as = 0.f;
        for (int ch = 0; ch < 3; ++ch) {
            g.c0[ch] = static_cast<float>(c[ch]);
            g.cs[ch] = 0.f;
        }
    };
    const double first = bounds_[0], last = bounds_[nb - 1];
    fillConstant(regions_[0], first, first - 1.0 - std::abs(first));
    for (std::size_t r = 1; r < nb; ++r) fill(regions_[r], bounds_[r - 1], bounds_[r]);
    fillConstant(regions_[nb], last, last + 1.0 + std::abs(last));

    // Bucket count: about 4 buckets per smallest gap between breakpoints, within [256, 16384].
    const double span = static_cast<double>(bounds_[nb - 1]) - static_cast<double>(bounds_[0]);
    double minGap = span;
    for (std::size_t i = 1; i < nb; ++i)
        minGap = std::min(minGap, static_cast<double>(bounds_[i]) - bounds_[i - 1]);
    int count = 256;
    while (count < 16384 && minGap > 0.0 && span / count > 0.25 * minGap) count *= 2;
    // Scale slightly below count/span so the last breakpoint lands in the last bucket.
    scale_ = span > 0.0 ? static_cast<float>(count / span * (1.0 - 1e-6)) : 0.f;
    maxBucket_ = static_cast<float>(count - 1);
    auto bucketOf = [&](float x) {  // the same float arithmetic as classify()
        float fb = (x - bounds_[0]) * scale_;
        fb = fb > 0.f ? fb : 0.f;
        fb = fb < maxBucket_ ? fb : maxBucket_;
        return static_cast<int>(fb);
    };
    const float inf = std::numeric_limits<float>::infinity();
    buckets_.assign(static_cast<std::size_t>(count), Bucket{inf, 0, 0});
    std::vector<int> inBucket(static_cast<std::size_t>(count), 0);
    for (std::size_t i = 0; i < nb; ++i) {
        const int k = bucketOf(bounds_[i]);
        if (inBucket[k]++ == 0) buckets_[k].split = bounds_[i];
    }
    int below = 0;
    for (int k = 0; k < count; ++k) {
        Bucket& b = buckets_[k];
        b.base = below;
        b.extra = inBucket[k] > 1 ? 1 : 0;
        // Regions below..below+inBucket[k] are the only ones x in this bucket can fall in.
        bool zero = true;
        for (int r = below; r <= below + inBucket[k]; ++r)
            zero = zero && regions_[r].a0 == 0.f && regions_[r].as == 0.f;
        below += inBucket[k];
        if (zero) b.base = -1;
    }

    simdFits_ = regions_.size() <= static_cast<std::size_t>(kMaxSimdRegions);
    if (simdFits_) {
        arrays_.boundCount = static_cast<int>(nb);
        for (int r = 0; r < kMaxSimdRegions; ++r) {
            arrays_.bound[r] =
                r < static_cast<int>(nb) ? bounds_[static_cast<std::size_t>(r)] : inf;
            const Region& g = regions_[std::min<std::size_t>(r, nb)];
            arrays_.x0[r] = g.x0;
            arrays_.a0[r] = g.a0;
            arrays_.as[r] = g.as;
            for (int ch = 0; ch < 3; ++ch) {
                arrays_.c0[ch][r] = g.c0[ch];
                arrays_.cs[ch][r] = g.cs[ch];
            }
        }
    }
}

}  // namespace udvr
