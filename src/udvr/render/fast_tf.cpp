#include "udvr/render/fast_tf.h"

#include <algorithm>
#include <cmath>

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

    bucketRegion_.assign(kBuckets, static_cast<int>(nb));
    const double span = static_cast<double>(bounds_[nb - 1]) - static_cast<double>(bounds_[0]);
    invBucket_ = span > 0.0 ? static_cast<float>(kBuckets / span) : 0.f;
    for (int k = 0; k < kBuckets; ++k) {
        const float edge = static_cast<float>(bounds_[0] + span * k / kBuckets);
        bucketRegion_[k] = static_cast<int>(std::upper_bound(bounds_.begin(), bounds_.end(), edge) -
                                            bounds_.begin());
    }
}

}  // namespace udvr
