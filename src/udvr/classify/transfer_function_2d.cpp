#include "udvr/classify/transfer_function_2d.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "udvr/classify/expected_tf2.h"
#include "udvr/util/check.h"

namespace udvr {
namespace {

// Cell index and fraction of coordinate v on n points over [lo, hi], clamped.
void locate(double v, double lo, double hi, int n, int& i, double& f) {
    const double s = (v - lo) / (hi - lo) * (n - 1);
    if (!(s > 0.0)) {  // also NaN → first point
        i = 0;
        f = 0.0;
    } else if (s >= n - 1) {
        i = n - 2;
        f = 1.0;
    } else {
        i = std::min(static_cast<int>(s), n - 2);
        f = s - i;
    }
}

// Merged closed ranges of axis coordinates whose line (column or row) or the cell beside it has
// α > 0; `positive(k)` says whether line k has any α > 0.
template <class Positive>
std::vector<std::pair<double, double>> lineRanges(int n, double lo, double hi, Positive positive) {
    const double inf = std::numeric_limits<double>::infinity();
    const auto at = [&](int k) { return lo + (hi - lo) * k / (n - 1); };
    std::vector<std::pair<double, double>> out;
    const auto add = [&](double a, double b) {
        if (!out.empty() && a <= out.back().second)
            out.back().second = std::max(out.back().second, b);
        else
            out.emplace_back(a, b);
    };
    if (positive(0)) add(-inf, at(0));
    for (int k = 0; k + 1 < n; ++k)
        if (positive(k) || positive(k + 1)) add(at(k), at(k + 1));
    if (positive(n - 1)) add(at(n - 1), inf);
    return out;
}

}  // namespace

std::array<double, 4> TransferFunction2D::colorOpacityAt(double x, double y) const {
    int i, j;
    double fx, fy;
    locate(x, x0, x1, width, i, fx);
    locate(y, y0, y1, height, j, fy);
    std::array<double, 4> out{};
    const float *p00 = point(i, j), *p10 = point(i + 1, j);
    const float *p01 = point(i, j + 1), *p11 = point(i + 1, j + 1);
    for (int ch = 0; ch < 4; ++ch) {
        const double lo = p00[ch] + fx * (p10[ch] - p00[ch]);
        const double hi = p01[ch] + fx * (p11[ch] - p01[ch]);
        out[ch] = lo + fy * (hi - lo);
    }
    return out;
}

Rgba TransferFunction2D::classify(double x, double y) const {
    const auto v = colorOpacityAt(x, y);
    return Rgba{static_cast<float>(v[3] * v[0]), static_cast<float>(v[3] * v[1]),
                static_cast<float>(v[3] * v[2]), static_cast<float>(v[3])};
}

std::vector<std::pair<double, double>> TransferFunction2D::nonZeroOpacityXRanges() const {
    // Columns with any α > 0, in one row-major pass.
    std::vector<char> opaque(static_cast<std::size_t>(width), 0);
    for (int j = 0; j < height; ++j)
        for (int i = 0; i < width; ++i) opaque[i] |= point(i, j)[3] > 0.f;
    return lineRanges(width, x0, x1, [&](int i) { return opaque[i] != 0; });
}

std::vector<float> TransferFunction2D::emptyCellDistances() const {
    const int cw = width - 1, ch = height - 1;
    const int far = width + height;
    std::vector<int> d(static_cast<std::size_t>(cw) * ch);
    const auto at = [&](int i, int j) -> int& { return d[static_cast<std::size_t>(j) * cw + i]; };
    for (int j = 0; j < ch; ++j)
        for (int i = 0; i < cw; ++i) {
            at(i, j) = cellOpaque(i, j) ? 0 : far;
        }
    // Chebyshev distance transform: two raster passes over the 8-neighbourhood (exact for the
    // max norm).
    for (int j = 0; j < ch; ++j)
        for (int i = 0; i < cw; ++i)
            for (const auto& [di, dj] : {std::pair{-1, 0}, {-1, -1}, {0, -1}, {1, -1}}) {
                const int a = i + di, b = j + dj;
                if (a >= 0 && a < cw && b >= 0) at(i, j) = std::min(at(i, j), at(a, b) + 1);
            }
    for (int j = ch - 1; j >= 0; --j)
        for (int i = cw - 1; i >= 0; --i)
            for (const auto& [di, dj] : {std::pair{1, 0}, {1, 1}, {0, 1}, {-1, 1}}) {
                const int a = i + di, b = j + dj;
                if (a >= 0 && a < cw && b < ch) at(i, j) = std::min(at(i, j), at(a, b) + 1);
            }
    return std::vector<float>(d.begin(), d.end());
}

bool TransferFunction2D::cellOpaque(int i, int j) const {
    return point(i, j)[3] > 0.f || point(i + 1, j)[3] > 0.f || point(i, j + 1)[3] > 0.f ||
           point(i + 1, j + 1)[3] > 0.f;
}

std::vector<float> TransferFunction2D::linearCellRuns(double tolerance) const {
    const int cw = width - 1;
    std::vector<float> runs(2 * static_cast<std::size_t>(cw) * (height - 1));
    for (int j = 0; j + 1 < height; ++j) {
        // The 8 sequences of the band: channels 0…3 of rows j and j + 1.
        const auto value = [&](int k, int i) {
            return static_cast<double>(point(i, j + k / 4)[k % 4]);
        };
        for (int lo = 0; lo < cw;) {
            const bool opaque = cellOpaque(lo, j);
            // A line from point lo's value with slope s passes within tolerance of every
            // interior point k iff s ∈ [sMin, sMax] (intersected per point, O(1) per step).
            double sMin[8], sMax[8];
            for (int k = 0; k < 8; ++k) {
                sMin[k] = -std::numeric_limits<double>::infinity();
                sMax[k] = std::numeric_limits<double>::infinity();
            }
            int hi = lo + 1;
            while (hi < cw && cellOpaque(hi, j) == opaque) {
                if (opaque) {  // point hi becomes interior; the run's end moves to hi + 1
                    bool linear = true;
                    double nMin[8], nMax[8];
                    for (int k = 0; k < 8 && linear; ++k) {
                        const double v0 = value(k, lo), step = hi - lo;
                        nMin[k] = std::max(sMin[k], (value(k, hi) - tolerance - v0) / step);
                        nMax[k] = std::min(sMax[k], (value(k, hi) + tolerance - v0) / step);
                        const double slope = (value(k, hi + 1) - v0) / (step + 1);
                        linear = slope >= nMin[k] && slope <= nMax[k];
                    }
                    if (!linear) break;
                    std::copy(nMin, nMin + 8, sMin);
                    std::copy(nMax, nMax + 8, sMax);
                }
                ++hi;
            }
            for (int i = lo; i < hi; ++i) {
                runs[2 * (static_cast<std::size_t>(j) * cw + i)] = static_cast<float>(lo);
                runs[2 * (static_cast<std::size_t>(j) * cw + i) + 1] = static_cast<float>(hi);
            }
            lo = hi;
        }
    }
    return runs;
}

std::vector<float> TransferFunction2D::identicalRowsUpTo() const {
    std::vector<float> out(static_cast<std::size_t>(height));
    out.back() = static_cast<float>(height - 1);
    for (int j = height - 2; j >= 0; --j) {
        const bool same = std::equal(point(0, j), point(0, j + 1), point(0, j + 1));
        out[j] = same ? out[j + 1] : static_cast<float>(j);
    }
    return out;
}

std::vector<float> TransferFunction2D::rowPrefixIntegrals() const {
    std::vector<float> out(static_cast<std::size_t>(width) * height * 8);
    for (int j = 0; j < height; ++j) {
        double sum[4] = {0.0, 0.0, 0.0, 0.0};
        for (int i = 0;; ++i) {
            float* o = out.data() + (static_cast<std::size_t>(j) * width + i) * 8;
            for (int ch = 0; ch < 4; ++ch) {
                o[ch] = static_cast<float>(sum[ch]);
                o[4 + ch] = static_cast<float>(sum[ch] - o[ch]);
            }
            if (i + 1 == width) break;
            // Cell [i, i + 1] is one unit of x: its integral is its mean over σ ∈ [0, 1].
            double cell[4];
            detail::Tf2RowCell<double>(rgba.data(), (j * width + i) * 4, true).mean(0.0, 1.0, cell);
            for (int ch = 0; ch < 4; ++ch) sum[ch] += cell[ch];
        }
    }
    return out;
}

std::vector<double> TransferFunction2D::bandPrefixMoments() const {
    constexpr int M = kTf2BandMoments;
    const std::size_t W = static_cast<std::size_t>(width), H = static_cast<std::size_t>(height);
    std::vector<double> out(((W - 1) * H + (H - 1) * W) * M, 0.0);
    // Band `band` of one orientation, its n lines along the other axis: corner(b, l, ch) is the
    // raster value at the band's line b ∈ {0, 1} (across) and line l along it.
    const auto fill = [&](double* table, int bands, int n, const auto& corner) {
        for (int band = 0; band < bands; ++band) {
            double* rec = table + static_cast<std::size_t>(band) * n * M;
            for (int l = 0; l + 1 < n; ++l) {
                double e[M];
                detail::bandCellMoments(
                    l,
                    [&](int b, int along, int ch) {
                        return static_cast<double>(corner(band + b, l + along, ch));
                    },
                    e);
                for (int m = 0; m < M; ++m) rec[(l + 1) * M + m] = rec[l * M + m] + e[m];
            }
        }
    };
    fill(out.data(), width - 1, height,
         [&](int i, int j, int ch) { return point(i, j)[ch]; });  // bands between x lines
    fill(out.data() + (W - 1) * H * M, height - 1, width,
         [&](int j, int i, int ch) { return point(i, j)[ch]; });  // bands between y lines
    return out;
}

void TransferFunction2D::validate() const {
    if (width < 2 || height < 2 || width > kMaxTf2Resolution || height > kMaxTf2Resolution)
        UDVR_FAIL("2D transfer function: needs 2x2 to "
                  << kMaxTf2Resolution << "x" << kMaxTf2Resolution << " points, got " << width
                  << "x" << height);
    if (rgba.size() != static_cast<std::size_t>(width) * height * 4)
        UDVR_FAIL("2D transfer function: expected " << width << "x" << height << "x4 values, got "
                                                    << rgba.size());
    // The kernels work in float raster coordinates: (v − x0)·(W − 1)/(x1 − x0) must be finite
    // and the step non-zero.
    const auto axis = [](double lo, double hi, int n, const char* name) {
        const float step = static_cast<float>((n - 1) / (hi - lo));
        if (!(std::isfinite(lo) && std::isfinite(hi) && lo < hi && std::isfinite(hi - lo) &&
              std::isfinite(step) && step > 0.f && std::isfinite(static_cast<float>(lo))))
            UDVR_FAIL("2D transfer function: " << name << " domain must be finite with " << name
                                               << "0 < " << name << "1 and a representable width, "
                                               << "got [" << lo << ", " << hi << "]");
    };
    axis(x0, x1, width, "x");
    axis(y0, y1, height, "y");
    for (std::size_t k = 0; k < rgba.size(); ++k)
        if (!(rgba[k] >= 0.f && rgba[k] <= 1.f))
            UDVR_FAIL("2D transfer function: colour and opacity must lie in [0,1] (point "
                      << k / 4 % width << "," << k / 4 / width << ")");
}

TransferFunction2D transferFunction2DFrom1D(const TransferFunction1D& tf, int width, double x0,
                                            double x1, double y0, double y1) {
    TransferFunction2D t;
    t.width = width;
    t.height = 2;
    t.x0 = x0;
    t.x1 = x1;
    t.y0 = y0;
    t.y1 = y1;
    t.rgba.resize(static_cast<std::size_t>(width) * 2 * 4);
    for (int i = 0; i < width; ++i) {
        const double x = x0 + (x1 - x0) * i / (width - 1);
        const auto c = tf.colorAt(x);
        const double a = tf.opacityAt(x);
        for (int j = 0; j < 2; ++j) {
            float* p = t.rgba.data() + (static_cast<std::size_t>(j) * width + i) * 4;
            for (int ch = 0; ch < 3; ++ch) p[ch] = static_cast<float>(c[ch]);
            p[3] = static_cast<float>(a);
        }
    }
    t.validate();
    return t;
}

}  // namespace udvr
