#include "udvr/classify/joint_distribution.h"

#include <algorithm>

#include "udvr/classify/expected_tf2_gaussian.h"
#include "udvr/classify/expected_tf2_uniform_exact.h"

namespace udvr {

void expectedTf2Over(const Tf2Raster<double>& tf, const JointPointDistribution& d, double out[4]) {
    ExpectationSum e;
    double v[4];
    for (const auto& p : d.points) {
        tf2At<double>(tf, p.x, p.g, true, v);
        e.add(p.mass, v);
    }
    for (const auto& s : d.segments) {
        tf2MeanAlongSegment<double>(tf, s.xa, s.ga, s.xb, s.gb, true, v);
        e.add(s.mass, v);
    }
    for (const auto& n : d.normals) {
        expectedTf2Gaussian(tf, n.piece.mx, n.piece.mg, n.piece.vxx, n.piece.vxg, n.piece.vgg, v);
        e.add(n.mass, v);
    }
    for (const auto& b : d.boxSplines) {
        Tf2UniformExactOptions options;
        expectedTf2UniformExact(tf, b.piece.cx, b.piece.cg, b.piece.d, b.piece.n, b.piece.tinyWidth,
                                options, v);
        e.add(b.mass, v);
    }
    std::copy(e.sum, e.sum + 4, out);
}

}  // namespace udvr
