#pragma once
// E[TF2(X, Y)] for two independent fields (SPEC §9 bivariate fields, the paper's §5.2 fuzzy
// fiber surfaces): x from the first field's distribution at the sample, y from the second's.
//
// Method (exact for every model). Inside raster cell (i, j) colour and α are each bilinear in
// the cell's local coordinates (s, t) ∈ [0,1]², so α·c is biquadratic and, X and Y independent,
//   E[α·c] = Σ_{i,j} Σ_{corners k, k'} α_k c_k' · E_x[φ_k φ_k'; X ∈ cell i] · E_y[ψ_k ψ_k'; Y ∈ j]
// with the hat functions φ ∈ {1 − s, s}, ψ ∈ {1 − t, t}. Each field therefore enters through
// three moments per raster cell along its axis, m_d = E[s^d; X ∈ cell], d = 0, 1, 2
// (AxisMoments), and the expectation is a sum over the cells both fields reach
// (expectedTf2Independent): O(cells_x × cells_y) per sample. Mass outside the domain sits at the
// end line it is clamped to (the TF2 is constant beyond it).
//
// A field's distribution reaches AxisMoments as pieces (a DistributionSink, point_distribution.h):
// point masses, uniform pieces (exact per-cell polynomials), and distributions known by their
// partial moments T_d(u) = E[(U − u)^d; U ≥ u] (normal in closed form, box spline by
// BoxSplineTail): cell moments are differences of T at consecutive raster lines, m_0 = T_0(i) −
// T_0(i+1), m_1 = T_1(i) − T_1(i+1) − T_0(i+1), m_2 = T_2(i) − T_2(i+1) − 2T_1(i+1) − T_0(i+1).
// Their absolute error is ~ε·(support in cells)², below 1e−8 for rasters up to 8192 cells.
#include <algorithm>
#include <cmath>
#include <vector>

#include "udvr/classify/expected_tf2.h"
#include "udvr/reconstruct/box_spline.h"
#include "udvr/util/normal_cdf.h"

namespace udvr {

/// One axis of a raster: points at origin + k/inv, k = 0 … points − 1; u = (x − origin)·inv is
/// the raster coordinate, cell i = [i, i + 1].
struct RasterAxis {
    double origin = 0.0, inv = 1.0;
    int points = 2;

    double coordinate(double x) const { return (x - origin) * inv; }
    int cells() const { return points - 1; }
};

/// Per-cell moments m_d = E[s^d; X ∈ cell] of a distribution along a raster axis, d = 0, 1, 2
/// (s the cell's local coordinate); cells lo … hi may be non-zero. Reused across samples:
/// reset() zeroes what the last sample touched.
class AxisMoments {
  public:
    /// Start a sample. Only cells windowLo … windowHi get moments (default: all): mass in
    /// other cells is dropped (callers pass the cells where the TF2 can have α > 0).
    void reset(const RasterAxis& axis, int windowLo = 0, int windowHi = -1) {
        for (int i = lo_; i <= hi_; ++i) m_[3 * i] = m_[3 * i + 1] = m_[3 * i + 2] = 0.0;
        axis_ = axis;
        m_.resize(3 * static_cast<std::size_t>(axis.cells()), 0.0);
        lo_ = axis.cells();
        hi_ = -1;
        windowLo_ = std::max(windowLo, 0);
        windowHi_ = windowHi < 0 ? axis.cells() - 1 : std::min(windowHi, axis.cells() - 1);
    }
    int lo() const { return lo_; }
    int hi() const { return hi_; }
    const double* at(int cell) const { return &m_[3 * static_cast<std::size_t>(cell)]; }

    void point(double x, double mass) { pointAt(axis_.coordinate(x), mass); }
    void uniform(double a, double b, double mass) {
        double ua = axis_.coordinate(a), ub = axis_.coordinate(b);
        const double n = axis_.cells(), density = mass / (ub - ua);
        if (!(ub > ua) || !std::isfinite(density)) {  // narrower than the rounding: a point
            pointAt(0.5 * (ua + ub), mass);
            return;
        }
        if (ua < 0.0) pointAt(0.0, density * (std::min(ub, 0.0) - ua));  // clamped below
        if (ub > n) pointAt(n, density * (ub - std::max(ua, n)));        // clamped above
        ua = std::max(ua, 0.0);
        ub = std::min(ub, n);
        if (!(ub > ua)) return;
        const int first = std::max(std::min(static_cast<int>(ua), axis_.cells() - 1), windowLo_);
        for (int i = first; i <= windowHi_ && i < ub; ++i) {
            const double s0 = std::max(ua - i, 0.0), s1 = std::min(ub - i, 1.0);
            if (!(s1 > s0)) continue;
            // m_1 = ρ(s1² − s0²)/2 and m_2 = ρ(s1³ − s0³)/3 factored through m_0 = ρ(s1 − s0):
            // the differences of powers cancel to nothing for pieces a few ulps wide (ρ ~ 1e15).
            const double m0 = density * (s1 - s0);
            add(i, m0, m0 * 0.5 * (s0 + s1), m0 * (s0 * s0 + s0 * s1 + s1 * s1) / 3.0);
        }
    }
    void normal(double mu, double sigma, double mass) {
        const double m = axis_.coordinate(mu), s = sigma * axis_.inv;
        if (!(s > 0.0) || !std::isfinite(m)) {
            pointAt(m, mass);
            return;
        }
        constexpr double kReach = 9.0;  // mass beyond μ ± 9σ (2e−19) is dropped
        fromTail(m - kReach * s, m + kReach * s, mass, [&](double u, double t[3]) {
            // z = (μ − u)/σ: T_0 = Φ(z), T_1 = σ(zΦ + φ), T_2 = σ²((z² + 1)Φ + zφ).
            const double z = (m - u) / s;
            const NormalCdfPdf n = normalCdfPdf(z);
            const double cdf = n.cdf, pdf = n.pdf;
            t[0] = cdf;
            t[1] = s * (z * cdf + pdf);
            t[2] = s * s * ((z * z + 1.0) * cdf + z * pdf);
        });
    }
    void boxSpline(const UniformSum& u, double mass) {
        UniformSum r = u;  // in raster units
        r.shift = axis_.coordinate(u.shift);
        for (int i = 0; i < r.n; ++i) r.h[i] = u.h[i] * axis_.inv;
        r.total = u.total * axis_.inv;
        const BoxSplineTail tail(r);
        fromTail(r.shift, r.shift + r.total, mass,
                 [&](double line, double t[3]) { tail.at(r.shift - line, t); });
    }

  private:
    void add(int i, double m0, double m1, double m2) {
        if (i < windowLo_ || i > windowHi_) return;
        double* p = &m_[3 * static_cast<std::size_t>(i)];
        p[0] += m0;
        p[1] += m1;
        p[2] += m2;
        lo_ = std::min(lo_, i);
        hi_ = std::max(hi_, i);
    }
    // A point mass at raster coordinate u (clamped onto the domain; NaN at the first line).
    void pointAt(double u, double mass) {
        const int cells = axis_.cells();
        u = u > 0.0 ? std::min(u, static_cast<double>(cells)) : 0.0;
        const int i = std::min(static_cast<int>(u), cells - 1);
        const double s = u - i;
        add(i, mass, mass * s, mass * s * s);
    }
    // mass × a distribution with support in [lo, hi] (raster units) known by its partial
    // moments tail(u, T) = E[(U − u)^d; U ≥ u]: cell moments by differences at the lines from
    // floor(lo) to ceil(hi) within the window; the mass below the domain sits on its first line
    // and the mass above on its last (where those cells are in the window).
    template <class Tail>
    void fromTail(double lo, double hi, double mass, const Tail& tail) {
        if (!(std::isfinite(lo) && std::isfinite(hi))) {
            pointAt(lo, mass);
            return;
        }
        const int cells = axis_.cells();
        double t[3];
        if (windowLo_ == 0) {
            tail(0.0, t);
            pointAt(0.0, mass * (1.0 - t[0]));
        }
        if (windowHi_ == cells - 1) {
            tail(static_cast<double>(cells), t);
            pointAt(cells, mass * t[0]);
        }
        const int l0 =
            std::max(static_cast<int>(std::floor(std::clamp(lo, 0.0, static_cast<double>(cells)))),
                     windowLo_);
        const int l1 =
            std::min(static_cast<int>(std::ceil(std::clamp(hi, 0.0, static_cast<double>(cells)))),
                     windowHi_ + 1);
        if (l0 >= l1) return;
        double prev[3];
        tail(static_cast<double>(l0), prev);
        for (int i = l0; i < l1; ++i) {
            double next[3];
            tail(static_cast<double>(i + 1), next);
            add(i, mass * (prev[0] - next[0]), mass * (prev[1] - next[1] - next[0]),
                mass * (prev[2] - next[2] - 2.0 * next[1] - next[0]));
            for (int d = 0; d < 3; ++d) prev[d] = next[d];
        }
    }

    RasterAxis axis_;
    std::vector<double> m_;
    int lo_ = 0, hi_ = -1;
    int windowLo_ = 0, windowHi_ = -1;
};

/// E[(α·r, α·g, α·b, α)] of a raster TF2 with X and Y independent, given their per-cell moments
/// along the raster's x and y axes (see the file comment). Cells whose four corners have α = 0
/// contribute nothing: rowCells (optional; per row of cells the first and last cell with α > 0)
/// bounds each row, and blocks of empty cells are jumped over (Tf2Raster::cellEmptyDistance).
inline void expectedTf2Independent(const Tf2Raster<double>& r, const AxisMoments& x,
                                   const AxisMoments& y, double out[4],
                                   const int* rowCells = nullptr) {
    for (int ch = 0; ch < 4; ++ch) out[ch] = 0.0;
    const int cw = r.width - 1;
    for (int j = y.lo(); j <= y.hi(); ++j) {
        const double* my = y.at(j);
        if (my[0] == 0.0) continue;
        // E[ψ_b ψ_b'] and E[ψ_b] for b, b' ∈ {0: 1 − t, 1: t}.
        const double py[2][2] = {{my[0] - 2.0 * my[1] + my[2], my[1] - my[2]},
                                 {my[1] - my[2], my[2]}};
        const double ey[2] = {my[0] - my[1], my[1]};
        const int i0 = rowCells ? std::max(x.lo(), rowCells[2 * j]) : x.lo();
        const int i1 = rowCells ? std::min(x.hi(), rowCells[2 * j + 1]) : x.hi();
        for (int i = i0; i <= i1; ++i) {
            if (r.cellEmptyDistance) {
                const float d = r.cellEmptyDistance[static_cast<std::size_t>(j) * cw + i];
                if (d > 0.f) {
                    i += static_cast<int>(d) - 1;
                    continue;
                }
            }
            const double* mx = x.at(i);
            if (mx[0] == 0.0) continue;
            const double px[2][2] = {{mx[0] - 2.0 * mx[1] + mx[2], mx[1] - mx[2]},
                                     {mx[1] - mx[2], mx[2]}};
            const double ex[2] = {mx[0] - mx[1], mx[1]};
            // Corner (i + a, j + b) at p[b][a].
            const float* p00 = r.rgba + (static_cast<std::size_t>(j) * r.width + i) * 4;
            const float* p[2][2] = {{p00, p00 + 4}, {p00 + 4 * r.width, p00 + 4 * r.width + 4}};
            // α·c = Σ α[a][b] c[a'][b'] φ_a φ_a' ψ_b ψ_b': with M[a][b'] = Σ_b α[a][b] py[b][b'],
            // E = Σ_{a,a'} px[a][a'] Σ_b' M[a][b'] c[a'][b'].
            double m[2][2];
            for (int a = 0; a < 2; ++a) {
                const double a0 = p[0][a][3], a1 = p[1][a][3];
                out[3] += ex[a] * (a0 * ey[0] + a1 * ey[1]);
                m[a][0] = a0 * py[0][0] + a1 * py[1][0];
                m[a][1] = a0 * py[0][1] + a1 * py[1][1];
            }
            for (int a = 0; a < 2; ++a)
                for (int a2 = 0; a2 < 2; ++a2) {
                    const double w0 = px[a][a2] * m[a][0], w1 = px[a][a2] * m[a][1];
                    for (int ch = 0; ch < 3; ++ch) out[ch] += w0 * p[0][a2][ch] + w1 * p[1][a2][ch];
                }
        }
    }
}

}  // namespace udvr
