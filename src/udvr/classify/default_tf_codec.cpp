// The default TF basis as field data (`default_tf`, docs/formats.md): encodeDefaultTfBasis and
// decodeDefaultTfBasis, apart from tf_presets.cpp so that the model readers (and their fuzz
// targets) link them without the gradient code the basis is computed with.
#include <cmath>

#include "udvr/classify/tf_presets.h"
#include "udvr/util/check.h"

namespace udvr {

std::vector<double> encodeDefaultTfBasis(const DefaultTfBasis& b) {
    std::vector<double> out{1.0, b.range[0], b.range[1], b.median, b.constant ? 1.0 : 0.0};
    for (std::size_t i = 0; i < b.opacityX.size(); ++i) {
        out.push_back(b.opacityX[i]);
        out.push_back(b.opacity[i]);
    }
    return out;
}

DefaultTfBasis decodeDefaultTfBasis(std::span<const double> e, const std::string& what) {
    const bool sized = e.size() >= 5 && (e.size() - 5) % 2 == 0 && e[0] == 1.0;
    bool ok = sized;
    for (double v : e) ok = ok && std::isfinite(v);
    DefaultTfBasis b;
    if (ok) {
        b.range = {e[1], e[2]};
        b.median = e[3];
        b.constant = e[4] != 0.0;
        ok = b.range[0] < b.range[1];
        for (std::size_t i = 5; ok && i < e.size(); i += 2) {
            ok = e[i + 1] >= 0.0 && e[i + 1] <= 1.0 &&
                 (b.opacityX.empty() || e[i] >= b.opacityX.back());
            b.opacityX.push_back(e[i]);
            b.opacity.push_back(e[i + 1]);
        }
    }
    if (!ok)
        UDVR_FAIL(what << ": field data 'default_tf' is malformed (expected 1, lo < hi, median, "
                          "constant, then (x, alpha) pairs with x rising and alpha in [0, 1])");
    return b;
}

}  // namespace udvr
