#include "udvr/classify/tf_presets.h"

#include <algorithm>
#include <cmath>

#include "udvr/stats/value_summary.h"
#include "udvr/util/check.h"
#include "udvr/util/text_parse.h"

namespace udvr {
namespace {

struct ColorStop {
    double t;  // position in [0, 1]
    std::array<double, 3> rgb;
};
struct Preset {
    const char* name;
    std::vector<ColorStop> stops;
};

// Control points of well-known colour maps (the published values of each map, thinned to a few
// stops; colours are linear between them as every 1D TF here).
const std::vector<Preset>& presets() {
    static const std::vector<Preset> all{
        // Moreland's diverging map, ParaView's default ("Cool to Warm").
        {"cool-to-warm",
         {{0.0, {0.231373, 0.298039, 0.752941}},
          {0.5, {0.865003, 0.865003, 0.865003}},
          {1.0, {0.705882, 0.0156863, 0.14902}}}},
        // matplotlib's viridis at 0, ¼, ½, ¾, 1.
        {"viridis",
         {{0.0, {0.267004, 0.004874, 0.329415}},
          {0.25, {0.229739, 0.322361, 0.545706}},
          {0.5, {0.127568, 0.566949, 0.550556}},
          {0.75, {0.369214, 0.788888, 0.382914}},
          {1.0, {0.993248, 0.906157, 0.143936}}}},
        // matplotlib's inferno at 0, ¼, ½, ¾, 1.
        {"inferno",
         {{0.0, {0.001462, 0.000466, 0.013866}},
          {0.25, {0.341500, 0.062325, 0.429425}},
          {0.5, {0.735683, 0.215906, 0.330245}},
          {0.75, {0.978422, 0.557937, 0.034931}},
          {1.0, {0.988362, 0.998364, 0.644924}}}},
        // ParaView's "Black-Body Radiation".
        {"black-body",
         {{0.0, {0.0, 0.0, 0.0}},
          {0.39, {0.901961, 0.0, 0.0}},
          {0.58, {0.901961, 0.901961, 0.0}},
          {1.0, {1.0, 1.0, 1.0}}}},
        {"grayscale", {{0.0, {0.0, 0.0, 0.0}}, {1.0, {1.0, 1.0, 1.0}}}},
    };
    return all;
}

const Preset* findPreset(std::string_view name) {
    for (const Preset& p : presets())
        if (name == p.name) return &p;
    return nullptr;
}

}  // namespace

std::vector<std::string> transferFunctionPresetNames() {
    std::vector<std::string> names;
    for (const Preset& p : presets()) names.emplace_back(p.name);
    return names;
}

std::string transferFunctionPresetList() {
    std::string list;
    for (const Preset& p : presets()) list += (list.empty() ? "" : ", ") + std::string(p.name);
    return list;
}

bool isTransferFunctionPreset(std::string_view name) { return findPreset(name) != nullptr; }

TransferFunction1D transferFunctionPreset(std::string_view name, std::array<double, 2> range,
                                          double rampStart) {
    const Preset* preset = findPreset(name);
    if (preset == nullptr)
        UDVR_FAIL("no transfer-function preset '"
                  << clipForMessage(name) << "'" << didYouMean(name, transferFunctionPresetNames())
                  << " (presets: " << transferFunctionPresetList() << ")");
    const double lo = range[0], hi = range[1];
    UDVR_CHECK_MSG(lo < hi, "a preset needs a non-empty range");
    TransferFunction1D tf;
    for (const ColorStop& s : preset->stops) {
        tf.colorX.push_back(lo + s.t * (hi - lo));
        tf.color.push_back(s.rgb);
    }
    const double start = std::clamp(rampStart, lo, hi);
    constexpr double kTopOpacity = 0.5;
    tf.opacityX = {lo, start, hi};
    tf.opacity = {0.0, 0.0, kTopOpacity};
    if (!(start < hi)) {  // the median at the top: ramp over the whole range instead
        tf.opacityX = {lo, hi};
        tf.opacity = {0.0, kTopOpacity};
    }
    tf.validate();
    return tf;
}

PresetOverValues transferFunctionPresetOver(std::string_view name, std::span<const float> values,
                                            const std::optional<std::array<double, 2>>& range) {
    const ValueSummary summary = summarizeValues(values);
    DefaultTfBasis basis;
    basis.range = robustRange(summary);
    basis.constant = !(summary.max > summary.min);
    basis.median = summary.percentile(50);
    return transferFunctionPresetOver(name, basis, range);
}

DefaultTfBasis defaultTfBasis(const Grid3& grid, std::span<const float> values) {
    UDVR_CHECK(values.size() == grid.pointCount());
    const ValueSummary summary = summarizeValues(values);
    DefaultTfBasis basis;
    basis.range = robustRange(summary);
    basis.constant = !(summary.max > summary.min);
    basis.median = summary.percentile(50);
    return basis;
}

DefaultTfBasis defaultTfBasisOf(const ModelVolume& model) {
    if (model.defaultTf.empty()) return defaultTfBasis(model.grid, model.mean);
    DefaultTfBasis b = decodeDefaultTfBasis(model.defaultTf, "the model");
    if (!b.opacityX.empty()) b.rule = "the full-resolution field's boundaries (recorded by build)";
    return b;
}

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

PresetOverValues transferFunctionPresetOver(std::string_view name, const DefaultTfBasis& basis,
                                            const std::optional<std::array<double, 2>>& range) {
    PresetOverValues p;
    p.range = range ? *range : basis.range;
    p.constant = basis.constant;
    p.rampStart = p.constant ? p.range[0] : basis.median;
    p.tf = transferFunctionPreset(name, p.range, p.rampStart);
    if (!range && basis.opacityX.size() >= 2) {  // the basis's own opacity curve
        p.tf.opacityX = basis.opacityX;
        p.tf.opacity = basis.opacity;
        p.tf.validate();
        p.opacityRule = basis.rule;
    }
    return p;
}

TransferFunction1D tangleTransferFunction() {
    TransferFunction1D tf;
    const double rgb[][4] = {{-6.95, 0.70, 0.05, 0.05}, {-4.50, 0.85, 0.10, 0.10},
                             {-2.00, 0.95, 0.55, 0.10}, {0.00, 1.00, 0.80, 0.20},
                             {1.50, 0.60, 0.80, 0.80},  {3.00, 0.25, 0.45, 0.95},
                             {35.24, 0.10, 0.20, 0.60}};
    for (const auto& p : rgb) {
        tf.colorX.push_back(p[0]);
        tf.color.push_back({p[1], p[2], p[3]});
    }
    const double pts[][2] = {{-6.95, 0}, {-5.5, 0}, {-4.5, 0.9}, {-3.5, 0}, {-0.6, 0}, {0, 0.45},
                             {0.6, 0},   {2.4, 0},  {3.0, 0.12}, {3.6, 0},  {35.24, 0}};
    for (const auto& p : pts) {
        tf.opacityX.push_back(p[0]);
        tf.opacity.push_back(p[1]);
    }
    return tf;
}

}  // namespace udvr
