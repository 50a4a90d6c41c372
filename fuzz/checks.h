#pragma once
// What a reader's result must satisfy (fuzz targets): the promises of its header.
#include <cmath>
#include <string>

#include "fuzz_target.h"
#include "udvr/stats/model_volume.h"
#include "udvr/util/field.h"

namespace udvr::fuzz {

/// dims ≥ 1, origin finite, spacing positive and finite; `values` = points × components
/// (counted without overflow).
inline void checkGrid(const Grid3& g, std::size_t values, std::size_t components,
                      const std::string& what) {
    long double points = 1;
    for (int a = 0; a < 3; ++a) {
        if (g.dims[a] < 1) finding(what + ": grid dim " + std::to_string(g.dims[a]));
        if (!std::isfinite(g.origin[a])) finding(what + ": non-finite origin");
        if (!(g.spacing[a] > 0.0) || !std::isfinite(g.spacing[a]))
            finding(what + ": spacing " + std::to_string(g.spacing[a]));
        points *= static_cast<long double>(g.dims[a]);
    }
    if (points * static_cast<long double>(components) != static_cast<long double>(values))
        finding(what + ": " + std::to_string(values) + " values for a grid of " +
                std::to_string(static_cast<double>(points)) + " points x " +
                std::to_string(components));
}

inline void checkFiniteValues(const std::vector<float>& v, const std::string& what) {
    for (float x : v)
        if (!std::isfinite(x)) finding(what + ": a non-finite value was accepted");
}

inline void checkField(const ScalarField& f, const std::string& what) {
    checkGrid(f.grid, f.values.size(), 1, what);
    checkFiniteValues(f.values, what);
}

inline void checkEnsemble(const Ensemble& e, const std::string& what) {
    if (e.members < 2) finding(what + ": ensemble of " + std::to_string(e.members) + " members");
    checkGrid(e.grid, e.values.size(), static_cast<std::size_t>(e.members), what);
    checkFiniteValues(e.values, what);
}

/// Every array present has points × its components values, all finite.
inline void checkModel(const ModelVolume& m, const std::string& what) {
    const auto array = [&](const std::vector<float>& v, std::size_t components, const char* name) {
        if (v.empty()) return;
        checkGrid(m.grid, v.size(), components, what + " array " + name);
        checkFiniteValues(v, what + " array " + name);
    };
    array(m.mean, 1, "mean");
    array(m.stddev, 1, "stddev");
    array(m.min, 1, "min");
    array(m.max, 1, "max");
    array(m.iqr, 2, "iqr");
    if (m.quantileCount < 0 || (!m.quantiles.empty() && m.quantileCount < 1))
        finding(what + ": quantile count " + std::to_string(m.quantileCount));
    array(m.quantiles, static_cast<std::size_t>(m.quantileCount) + 1, "quantiles");
    if (!m.quantileLevels.empty() &&
        m.quantileLevels.size() != static_cast<std::size_t>(m.quantileCount) + 1)
        finding(what + ": quantile levels do not match the quantile count");
    if (m.gmmComponents < 0 || (!m.gmm.empty() && m.gmmComponents < 1))
        finding(what + ": gmm components " + std::to_string(m.gmmComponents));
    array(m.gmm, 3 * static_cast<std::size_t>(m.gmmComponents), "gmm");
}

}  // namespace udvr::fuzz

namespace udvr::fuzz {

/// Runs `check` on a result a reader returned; any exception from it is a finding (a reader
/// must not return what its own type's validation rejects).
template <class F>
void mustHold(F&& check, const std::string& what) {
    try {
        check();
    } catch (const Finding&) {
        throw;
    } catch (const std::exception& e) {
        finding(what + ": " + e.what());
    }
}

}  // namespace udvr::fuzz
