#include "udvr/classify/point_distribution.h"

namespace udvr {

double PointDistribution::continuousMass() const {
    double m = 0.0;
    for (const Uniform& p : uniforms) m += p.mass;
    for (const Normal& p : normals) m += p.mass;
    for (const BoxSpline& p : boxSplines) m += p.mass;
    return m;
}

std::pair<double, double> PointDistribution::support(double sigmas) const {
    double lo = INFINITY, hi = -INFINITY;
    const auto cover = [&](double a, double b) {
        lo = std::min(lo, a);
        hi = std::max(hi, b);
    };
    for (const Atom& p : atoms) cover(p.x, p.x);
    for (const Uniform& p : uniforms) cover(p.a, p.b);
    for (const Normal& p : normals) cover(p.mu - sigmas * p.sigma, p.mu + sigmas * p.sigma);
    for (const BoxSpline& p : boxSplines) cover(p.piece.shift, p.piece.shift + p.piece.total);
    if (lo > hi) return {0.0, 0.0};
    return {lo, hi};
}

std::vector<double> PointDistribution::continuousCdf(double lo, double hi, int n) const {
    std::vector<BoxSplineTail> tails;  // built once: each holds the box spline's moment tables
    for (const BoxSpline& p : boxSplines) tails.emplace_back(p.piece);
    std::vector<double> cdf(static_cast<std::size_t>(n) + 1);
    for (int i = 0; i <= n; ++i) {
        const double x = lo + (hi - lo) * i / n;
        double s = 0.0;
        for (const Uniform& p : uniforms) s += p.mass * std::clamp((x - p.a) / (p.b - p.a), 0., 1.);
        for (const Normal& p : normals) s += p.mass * normalCdf((x - p.mu) / p.sigma);
        for (std::size_t k = 0; k < tails.size(); ++k) {
            double t[3];
            tails[k].at(boxSplines[k].piece.shift - x, t);  // t[0] = P(X ≥ x)
            s += boxSplines[k].mass * (1.0 - t[0]);
        }
        cdf[static_cast<std::size_t>(i)] = s;
    }
    return cdf;
}

void expectedTfOver(const TfPieces<double>& tf, const PointDistribution& d, double out[4]) {
    ExpectationSum e;
    double v[4];
    for (const auto& p : d.atoms) {
        tfAt<double>(tf, p.x, v);
        e.add(p.mass, v);
    }
    for (const auto& p : d.uniforms) {
        tfMeanOver<double>(tf, p.a, p.b, tf.pieceOf(p.a), tf.pieceOf(p.b), v);
        e.add(p.mass, v);
    }
    for (const auto& p : d.normals) {
        expectedTfGaussian<double>(tf, p.mu, p.sigma, true, v);
        e.add(p.mass, v);
    }
    for (const auto& p : d.boxSplines) {
        expectedTfUniformSum(tf, p.piece, v);
        e.add(p.mass, v);
    }
    std::copy(e.sum, e.sum + 4, out);
}

}  // namespace udvr
