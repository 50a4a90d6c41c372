#pragma once
// An exact, fast evaluator of a piecewise-linear 1D transfer function (SPEC §4) for the ray loop:
// the colour and opacity breakpoints are merged into regions on which α(x) and c(x) are both
// linear, so TF(x) = (α·c, α) needs one region lookup (a uniform bucket grid plus a short scan)
// and a few multiply-adds. Same values as TransferFunction1D::classify up to float rounding,
// including right-continuous steps and clamping outside the control points.
#include <vector>

#include "udvr/classify/transfer_function.h"

namespace udvr {

class FastTransferFunction {
  public:
    explicit FastTransferFunction(const TransferFunction1D& tf);

    /// (α·r, α·g, α·b, α) at data value x.
    Rgba classify(float x) const {
        const Region& g = regions_[regionOf(x)];
        const float dx = x - g.x0;
        const float a = g.a0 + g.as * dx;
        const float r = g.c0[0] + g.cs[0] * dx;
        const float gg = g.c0[1] + g.cs[1] * dx;
        const float b = g.c0[2] + g.cs[2] * dx;
        return Rgba{a * r, a * gg, a * b, a};
    }
    /// Opacity only (cheaper; used to reject transparent samples early).
    float opacity(float x) const {
        const Region& g = regions_[regionOf(x)];
        return g.a0 + g.as * (x - g.x0);
    }

  private:
    struct Region {
        float x0;            // left end (data units); the region is [x0, next boundary)
        float a0, as;        // α = a0 + as·(x − x0)
        float c0[3], cs[3];  // c = c0 + cs·(x − x0)
    };
    // Region index r: bounds_[r−1] ≤ x < bounds_[r] (region 0 below bounds_[0], the last one at
    // or above bounds_.back()).
    int regionOf(float x) const {
        const int nb = static_cast<int>(bounds_.size());
        if (!(x >= bounds_[0])) return 0;
        if (x >= bounds_[nb - 1]) return nb;
        float fb = (x - bounds_[0]) * invBucket_;
        int k = static_cast<int>(fb);
        if (k >= kBuckets) k = kBuckets - 1;
        int r = bucketRegion_[k];
        while (r > 1 && x < bounds_[r - 1]) --r;
        while (r < nb && x >= bounds_[r]) ++r;
        return r;
    }

    static constexpr int kBuckets = 2048;
    std::vector<float> bounds_;      // merged breakpoints, strictly increasing
    std::vector<Region> regions_;    // bounds_.size() + 1 regions
    std::vector<int> bucketRegion_;  // region of each bucket's left edge
    float invBucket_ = 0.f;
};

}  // namespace udvr
