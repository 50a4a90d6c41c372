#pragma once
// E[TF2(X, G)] for the `uniform` model (SPEC §9): (X, G) = (cx, cy) + Σ_i t_i·(a_i, b_i) with
// t_i ~ U[−1, 1] independent, (a_i, b_i) = h_i·(w_i, u_i) (h_i the voxel's half width, w_i its
// trilinear weight, u_i = n̂·g_i): the paper's bivariate box spline with up to 32 directions.
// `uniform-exact` takes expectedTf2UniformExact (expected_tf2_uniform_exact.h: within 1e−6).
// Error against the exact evaluation and cost: docs/models.md.
#include "udvr/classify/expected_tf2.h"
#include "udvr/classify/expected_tf2_uniform_exact.h"

namespace udvr {

/// E[(α·c, α)(X, G)] for (X, G) = (cx, cy) + Σ_i t_i·d_i by expectedTf2UniformExact over `rd`:
/// `exact` (the `uniform-exact` model) at its defaults (error ≤ 1e−6), else (`uniform`, since
/// issue 33) at the coarser kUniform2DFast settings (measured max 1.8e−4 from the converged
/// value over random rough rasters, ~11× cheaper; docs/models.md).
inline constexpr Tf2UniformExactOptions kUniform2DFast{32, 1e-5, 2};
inline void expectedTf2Uniform(const Tf2Raster<double>& rd, double cx, double cy,
                               const BoxDirection2* d, int n, bool exact, double tinyWidth,
                               double out[4]) {
    Tf2UniformExactOptions opt = exact ? Tf2UniformExactOptions{} : kUniform2DFast;
    expectedTf2UniformExact(rd, cx, cy, d, n, tinyWidth, opt, out);
}

}  // namespace udvr
