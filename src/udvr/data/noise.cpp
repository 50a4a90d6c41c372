#include "udvr/data/noise.h"

#include <algorithm>
#include <cmath>

#include "udvr/util/check.h"
#include "udvr/util/parallel.h"
#include "udvr/util/random.h"
#include "udvr/util/text_parse.h"

namespace udvr {

NoiseKind parseNoiseKind(const std::string& name) {
    if (name == "bimodal") return NoiseKind::Bimodal;
    if (name == "gaussian") return NoiseKind::Gaussian;
    if (name == "uniform") return NoiseKind::Uniform;
    UDVR_FAIL("unknown noise '" << clipForMessage(name) << "'"
                                << didYouMean(name, {"bimodal", "gaussian", "uniform"})
                                << "; expected bimodal, gaussian or uniform");
}

Ensemble perturbField(const ScalarField& truth, int members, const NoiseParams& p) {
    if (members < 2) UDVR_FAIL("--members must be at least 2, got " << members);
    // Name the flag in the error: the user set one of them.
    const auto checkMagnitude = [](double v, const char* flag) {
        if (!(v >= 0) || !std::isfinite(v))
            UDVR_FAIL(flag << " must be finite and non-negative, got " << v);
    };
    checkMagnitude(p.sigma, "--sigma");
    checkMagnitude(p.width, "--width");
    checkMagnitude(p.outlierSigma, "--outlier-sigma");
    if (!std::isfinite(p.outlierOffset))
        UDVR_FAIL("--outlier-offset must be finite, got " << p.outlierOffset);
    if (!(p.outlierFraction >= 0 && p.outlierFraction <= 1))
        UDVR_FAIL("--outlier-fraction must lie in [0,1], got " << p.outlierFraction);
    const std::size_t n = truth.grid.pointCount();
    if (truth.values.size() != n)
        UDVR_FAIL("field has " << truth.values.size() << " values, grid needs " << n);
    auto [lo, hi] = std::minmax_element(truth.values.begin(), truth.values.end());
    double range = static_cast<double>(*hi) - static_cast<double>(*lo);
    if (!(range > 0)) range = 1.0;  // a constant field: magnitudes become absolute

    Ensemble ens;
    ens.grid = truth.grid;
    ens.members = members;
    ens.name = truth.name.empty() ? "value" : truth.name;
    ens.values.resize(n * static_cast<std::size_t>(members));
    const std::size_t grain = 1 << 14;
    parallelForChunks(n, grain, [&](std::size_t v0, std::size_t v1) {
        for (int m = 0; m < members; ++m) {
            float* out = ens.member(m);
            for (std::size_t v = v0; v < v1; ++v) {
                CounterRng rng(p.seed, static_cast<std::uint64_t>(m), v);
                const double t = truth.values[v];
                double x = t;
                switch (p.kind) {
                    case NoiseKind::Bimodal:
                        if (rng.uniform() < p.outlierFraction)
                            x = t + p.outlierOffset * range + p.outlierSigma * range * rng.normal();
                        else
                            x = t + p.sigma * range * rng.normal();
                        break;
                    case NoiseKind::Gaussian:
                        x = t + p.sigma * range * rng.normal();
                        break;
                    case NoiseKind::Uniform:
                        x = t + p.width * range * (2.0 * rng.uniform() - 1.0);
                        break;
                }
                out[v] = static_cast<float>(x);
            }
        }
    });
    return ens;
}

}  // namespace udvr
