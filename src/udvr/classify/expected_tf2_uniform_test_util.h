#pragma once
// Shared by the tests of the `uniform` model's 2D TF classification (expectedTf2UniformExact
// and the fast form): rasters sampled from a function, random box-spline cases,
// and the closed form of E[TF2] for bilinear α and c from the box spline's moments.
#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "udvr/classify/expected_tf2_uniform_exact.h"

namespace udvr::testing {

// A W×H raster over [x0, x1] × [y0, y1] sampling f(x, y) → (c_r, c_g, c_b, α).
struct Raster {
    std::vector<float> rgba;
    Tf2Raster<double> r;
    Raster(int W, int H, double x0, double x1, double y0, double y1,
           const std::function<void(double, double, double[4])>& f) {
        r.width = W, r.height = H, r.x0 = x0, r.y0 = y0;
        r.invDx = (W - 1) / (x1 - x0), r.invDy = (H - 1) / (y1 - y0);
        for (int j = 0; j < H; ++j)
            for (int i = 0; i < W; ++i) {
                double v[4];
                f(x0 + i / r.invDx, y0 + j / r.invDy, v);
                for (double c : v) rgba.push_back(static_cast<float>(c));
            }
        r.rgba = rgba.data();
    }
};

struct Case {
    double cx = 0, cy = 0;
    std::vector<BoxDirection2> d;
};

// `corners` directions with a ∈ (0.02, aMax] (random sign) and b ∈ [−bMax, bMax], `yOnly` with
// a = 0, b ∈ [−yMax, yMax].
inline Case randomCase(std::mt19937_64& g, int corners, int yOnly, double aMax, double bMax,
                       double yMax) {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    Case c;
    c.cx = u(g) - 0.5, c.cy = u(g) - 0.5;
    for (int i = 0; i < corners; ++i)
        c.d.push_back(
            {(u(g) < 0.5 ? -1 : 1) * (0.02 + (aMax - 0.02) * u(g)), bMax * (2 * u(g) - 1)});
    for (int i = 0; i < yOnly; ++i) c.d.push_back({0.0, yMax * (2 * u(g) - 1)});
    std::shuffle(c.d.begin(), c.d.end(), g);
    return c;
}

// Raw moments E[X^i G^j], i, j ≤ 2, of (X, G) = (cx, cy) + Σ_k t_k·(a_k, b_k), t_k ~ U[−1, 1]
// independent: the point's, convolved with each direction's (E[t^n] = 1/(n + 1), n even).
inline std::array<std::array<double, 3>, 3> boxSplineMoments(const Case& c) {
    std::array<std::array<double, 3>, 3> M{};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) M[i][j] = std::pow(c.cx, i) * std::pow(c.cy, j);
    const double binom[3][3] = {{1, 0, 0}, {1, 1, 0}, {1, 2, 1}};
    for (const BoxDirection2& d : c.d) {
        const auto dirMoment = [&](int i, int j) {  // E[(t a)^i (t b)^j]
            const int n = i + j;
            return n % 2 ? 0.0 : std::pow(d.a, i) * std::pow(d.b, j) / (n + 1);
        };
        std::array<std::array<double, 3>, 3> N{};
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                for (int k = 0; k <= i; ++k)
                    for (int l = 0; l <= j; ++l)
                        N[i][j] += binom[i][k] * binom[j][l] * M[k][l] * dirMoment(i - k, j - l);
        M = N;
    }
    return M;
}

// E[(α·c, α)(X, G)] for α and c bilinear: v_ch = P + Q·(x − x0) + S·y + T·(x − x0)·y, from the
// moments of (X − x0, G) (polynomials of degree ≤ 2 in each).
struct Bilinear {
    double P[4], Q[4], S[4], T[4], x0 = 0;
    void operator()(double x, double y, double v[4]) const {
        for (int ch = 0; ch < 4; ++ch)
            v[ch] = P[ch] + Q[ch] * (x - x0) + S[ch] * y + T[ch] * (x - x0) * y;
    }
    void expectation(Case c, double want[4]) const {
        c.cx -= x0;
        const auto M = boxSplineMoments(c);
        const auto product = [&](int u, int v) {  // E[v_u·v_v] by monomials x^i y^j
            const double A[2][2] = {{P[u], S[u]}, {Q[u], T[u]}},
                         B[2][2] = {{P[v], S[v]}, {Q[v], T[v]}};
            double e = 0;
            for (int i = 0; i < 2; ++i)
                for (int j = 0; j < 2; ++j)
                    for (int k = 0; k < 2; ++k)
                        for (int l = 0; l < 2; ++l) e += A[i][j] * B[k][l] * M[i + k][j + l];
            return e;
        };
        for (int ch = 0; ch < 3; ++ch) want[ch] = product(ch, 3);
        want[3] = P[3] + Q[3] * M[1][0] + S[3] * M[0][1] + T[3] * M[1][1];
    }
};

}  // namespace udvr::testing
