#include "udvr/classify/probe.h"

#include <algorithm>
#include <cmath>

namespace udvr {
namespace {

using nlohmann::json;

constexpr int kCdfSamples = 2048;

// Samples a continuous CDF over [lo, hi].
template <class Cdf>
void sampleCdf(ProbeDistribution& d, Cdf cdf) {
    d.continuousMass = 1.0;
    if (!(d.hi > d.lo)) {  // degenerate: a point
        d.atoms = {d.lo};
        d.atomMass = {1.0};
        d.continuousMass = 0.0;
        d.lo -= 0.5, d.hi += 0.5;
        return;
    }
    for (int i = 0; i <= kCdfSamples; ++i) {
        const double x = d.lo + (d.hi - d.lo) * i / kCdfSamples;
        d.cdfX.push_back(x);
        d.cdfY.push_back(cdf(x));
    }
}

void pad(ProbeDistribution& d, double fraction) {
    const double w = d.hi - d.lo;
    d.lo -= fraction * w;
    d.hi += fraction * w;
}

}  // namespace

ProbeResult probeModel(const ModelVolume& model, ModelKind kind, const TransferFunction1D& tf,
                       const std::array<double, 3>& point, const ClassifyOptions& options) {
    if (kind == ModelKind::GmmMc)
        UDVR_FAIL(
            "model 'gmm-mc' is defined by Monte Carlo realizations of whole images; probe "
            "'gmm-ordered' for the mixture at a point");
    for (int a = 0; a < 3; ++a)
        if (!(point[a] >= 0.0 && point[a] <= model.grid.dims[a] - 1))
            UDVR_FAIL("--point " << point[0] << "," << point[1] << "," << point[2]
                                 << " is outside the grid: index coordinates must lie in [0,"
                                 << model.grid.dims[0] - 1 << "]x[0," << model.grid.dims[1] - 1
                                 << "]x[0," << model.grid.dims[2] - 1 << "]");
    checkModelHasArrays(model, kind, options);
    const float px = static_cast<float>(point[0]), py = static_cast<float>(point[1]),
                pz = static_cast<float>(point[2]);
    ProbeResult r{kind, point, {}, json::object(), {}};
    withKernel(model, kind, tf, options,
               [&](const auto& k) { r.expected = classifyExact(k, px, py, pz); });

    const TfPiecesStorage pieces(tf);
    const CellGeometry geometry(model.grid);
    const Cell<double> cell = cellAt<double>(geometry, px, py, pz);
    double weights[8];
    trilinearWeights(cell, weights);
    json& j = r.json;
    j["model"] = std::string(modelName(kind));
    j["point"] = {point[0], point[1], point[2]};
    j["expected_rgba"] = {r.expected.r, r.expected.g, r.expected.b, r.expected.a};
    json corners = json::array();
    for (int c = 0; c < 8; ++c)
        if (weights[c] > 0.0)
            corners.push_back(
                {{"voxel", cornerVoxel(geometry, cell.base, c)}, {"weight", weights[c]}});
    j["corners"] = corners;
    const auto meanAt = [&](const float* values, int perVoxel = 1) {
        return trilinear(geometry, values, perVoxel, cell, true);
    };
    if (!model.mean.empty()) j["value"] = meanAt(model.mean.data());

    ProbeDistribution& d = r.distribution;
    switch (kind) {
        case ModelKind::Mean: {
            const double v = meanAt(model.mean.data());
            d.lo = d.hi = v;
            sampleCdf(d, [](double) { return 0.0; });
            break;
        }
        case ModelKind::Gaussian: {
            double mu, sigma;
            GaussianKernel(model.grid, model.mean.data(), model.stddev.data(), pieces)
                .paramsAt<double>(cell, true, mu, sigma);
            j["mean"] = mu;
            j["stddev"] = sigma;
            d.lo = mu - 4 * sigma, d.hi = mu + 4 * sigma;
            sampleCdf(d, [&](double x) { return normalCdf((x - mu) / sigma); });
            break;
        }
        case ModelKind::Uniform: {
            const auto range = modelDataRange(model);
            const UniformKernel uk(
                model.grid, options.uniformMinMax ? model.min.data() : model.mean.data(),
                options.uniformMinMax ? model.max.data() : model.stddev.data(),
                options.uniformMinMax, kUniformTinyWidth * (range.second - range.first), pieces);
            json terms = json::array();
            for (int c = 0; c < 8; ++c) {
                if (weights[c] == 0.0) continue;
                double lo, hi;
                uk.interval(cornerVoxel(geometry, cell.base, c), lo, hi);
                terms.push_back(
                    {{"weight", weights[c]}, {"low", weights[c] * lo}, {"high", weights[c] * hi}});
            }
            const UniformSum u = uk.sumAt(cell);
            j["terms"] = terms;
            j["mean"] = u.mean();
            j["stddev"] = std::sqrt(u.variance());
            j["low"] = u.shift;
            j["high"] = u.shift + u.total;
            d.lo = u.shift, d.hi = u.shift + u.total;
            pad(d, 0.05);
            if (u.n == 0) {
                d.lo = d.hi = u.shift;
                sampleCdf(d, [](double) { return 0.0; });
            } else {
                const BoxSplineTail tail(u);
                sampleCdf(d, [&](double x) {
                    double t[3];
                    tail.at(u.shift - x, t);  // t[0] = P(X ≥ x)
                    return 1.0 - t[0];
                });
            }
            break;
        }
        case ModelKind::GmmOrdered: {
            const int K = model.gmmComponents;
            std::vector<double> pi(K), mu(K), sg(K);
            GmmOrderedKernel(model.grid, model.gmm.data(), K, pieces)
                .componentsAt<double>(cell, true, pi.data(), mu.data(), sg.data());
            j["weights"] = pi;
            j["means"] = mu;
            j["sigmas"] = sg;
            d.lo = INFINITY, d.hi = -INFINITY;
            for (int k = 0; k < K; ++k) {
                if (pi[k] <= 0) continue;
                if (sg[k] > 0) {
                    d.lo = std::min(d.lo, mu[k] - 4 * sg[k]);
                    d.hi = std::max(d.hi, mu[k] + 4 * sg[k]);
                } else {
                    d.atoms.push_back(mu[k]);
                    d.atomMass.push_back(pi[k]);
                    d.lo = std::min(d.lo, mu[k]);
                    d.hi = std::max(d.hi, mu[k]);
                }
            }
            const std::vector<double> atoms = d.atoms, masses = d.atomMass;
            sampleCdf(d, [&](double x) {
                double s = 0;
                for (int k = 0; k < K; ++k)
                    if (sg[k] > 0) s += pi[k] * normalCdf((x - mu[k]) / sg[k]);
                return s;
            });
            if (!atoms.empty()) {  // sampleCdf may have replaced atoms for a degenerate range
                d.atoms = atoms;
                d.atomMass = masses;
                double cont = 0;
                for (int k = 0; k < K; ++k)
                    if (sg[k] > 0) cont += pi[k];
                d.continuousMass = cont;
            }
            break;
        }
        case ModelKind::Iqr:
        case ModelKind::QuantileRange:
        case ModelKind::QuartileLower:
        case ModelKind::QuartileMiddle:
        case ModelKind::QuartileUpper:
        case ModelKind::QuantileMean:
        case ModelKind::QuantileMeanMass: {
            const bool iqr = kind == ModelKind::Iqr;
            const int q = iqr ? 1 : model.quantileCount;
            std::vector<double> b(static_cast<std::size_t>(q) + 1);
            for (int i = 0; i <= q; ++i)
                b[i] = boundaryAt<double>(geometry, iqr ? model.iqr.data() : model.quantiles.data(),
                                          q + 1, i, cell, true);
            j["boundaries"] = b;
            int j0 = 0, j1 = q;
            if (!iqr && kind != ModelKind::QuantileMean && kind != ModelKind::QuantileMeanMass) {
                std::tie(j0, j1) = quantilePopulation(kind, q, options);
                j["population"] = {j0, j1};
            }
            if (kind == ModelKind::QuantileMean || kind == ModelKind::QuantileMeanMass) {
                // Discrete: midpoints m_j with weights p_j (Eq. 5).
                const auto range = modelDataRange(model);
                const double zero = kQuantileZeroWidth * (range.second - range.first);
                int zeros = 0;
                for (int i = 1; i <= q; ++i) zeros += (b[i] - b[i - 1] <= zero);
                double ws = 0;
                std::vector<double> w(static_cast<std::size_t>(q));
                for (int i = 1; i <= q; ++i) {
                    const double wi = b[i] - b[i - 1];
                    w[i - 1] = kind == ModelKind::QuantileMeanMass
                                   ? 1.0
                                   : (zeros ? (wi <= zero ? 1.0 : 0.0) : 1.0 / wi);
                    ws += w[i - 1];
                }
                std::vector<double> mids, probs;
                for (int i = 1; i <= q; ++i) {
                    mids.push_back(0.5 * (b[i - 1] + b[i]));
                    probs.push_back(w[i - 1] / ws);
                }
                j["midpoints"] = mids;
                j["probabilities"] = probs;
                d.lo = b[0], d.hi = b[q];
                pad(d, 0.05);
                d.atoms = mids;
                d.atomMass = probs;
                break;
            }
            d.lo = b[j0], d.hi = b[j1];
            pad(d, 0.05);
            const std::vector<double> bb = b;
            // Zero-width quantiles inside the population are point masses of 1/(j1−j0).
            for (int i = j0 + 1; i <= j1; ++i)
                if (!(bb[i] > bb[i - 1])) {
                    d.atoms.push_back(bb[i]);
                    d.atomMass.push_back(1.0 / (j1 - j0));
                }
            const std::vector<double> atoms = d.atoms, masses = d.atomMass;
            sampleCdf(d, [&](double x) {
                double s = 0;
                for (int i = j0 + 1; i <= j1; ++i) {
                    const double w = bb[i] - bb[i - 1];
                    if (!(w > 0)) continue;
                    s += std::clamp((x - bb[i - 1]) / w, 0.0, 1.0) / (j1 - j0);
                }
                return s;
            });
            d.atoms = atoms;
            d.atomMass = masses;
            d.continuousMass = 1.0 - static_cast<double>(atoms.size()) / (j1 - j0);
            break;
        }
        case ModelKind::GmmMc:
            break;
    }
    return r;
}

}  // namespace udvr
