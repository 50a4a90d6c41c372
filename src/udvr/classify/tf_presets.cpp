#include "udvr/classify/tf_presets.h"

#include <algorithm>
#include <cmath>

#include "udvr/reconstruct/gradient_field.h"
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

// One control point of a preset's colour map: a row of data/tf_presets.csv.
struct StopRow {
    const char* name;
    double t, r, g, b;
};
// The rows, as CMake writes them from data/tf_presets.csv (cmake/tf_presets.cmake).
constexpr StopRow kStopRows[] = {
#include "tf_preset_stops.inc"
};

// The presets in the file's order, each of its consecutive rows of one name (the published
// values of well-known colour maps, thinned to a few stops; colours are linear between them
// as in every 1D TF here).
const std::vector<Preset>& presets() {
    static const std::vector<Preset> all = [] {
        std::vector<Preset> out;
        for (const StopRow& row : kStopRows) {
            if (out.empty() || std::string_view(out.back().name) != row.name)
                out.push_back({row.name, {}});
            out.back().stops.push_back({row.t, {row.r, row.g, row.b}});
        }
        return out;
    }();
    return all;
}

const Preset* findPreset(std::string_view name) {
    for (const Preset& p : presets())
        if (name == p.name) return &p;
    return nullptr;
}

// The basis of the ramp from the median over `values` (finite, non-empty): their robust range,
// whether they are constant, their median; no opacity curve.
DefaultTfBasis rampBasis(std::span<const float> values) {
    const ValueSummary summary = summarizeValues(values);
    DefaultTfBasis basis;
    basis.range = robustRange(summary);
    basis.constant = !(summary.max > summary.min);
    basis.median = summary.percentile(50);
    return basis;
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
    return transferFunctionPresetOver(name, rampBasis(values), range);
}

DefaultTfBasis defaultTfBasis(const Grid3& grid, std::span<const float> values) {
    UDVR_CHECK(values.size() == grid.pointCount());
    DefaultTfBasis basis = rampBasis(values);
    if (basis.constant || values.size() < 64) return basis;
    // Boundary emphasis (Kindlmann & Durkin 1998): the mean gradient magnitude g(v) of the
    // points whose value falls in each of kBins bins over the range; values where g(v) stands
    // above the volume's typical gradient (its median: the noise of air and of homogeneous
    // material) are boundaries, and get opacity in proportion, up to 0.5.
    constexpr int kBins = 64, kPoints = 16;
    constexpr double kCut = 0.2;
    // SPEC §9's grid gradients (central differences, world units), as planes x, y, z.
    const std::vector<float> planes = gridGradients(grid, values.data(), 1, 0, 1);
    const std::size_t n = values.size();
    std::vector<float> g(n);
    for (std::size_t p = 0; p < n; ++p)
        g[p] = std::hypot(planes[p], planes[n + p], planes[2 * n + p]);
    const double lo = basis.range[0], hi = basis.range[1], w = (hi - lo) / kBins;
    std::vector<double> sum(kBins, 0.0), count(kBins, 0.0), face(kBins, 0.0);
    const auto& d = grid.dims;
    double faces = 0.0;
    for (std::size_t p = 0; p < values.size(); ++p) {
        const double b = (values[p] - lo) / w;
        if (!(b >= 0.0 && b < kBins)) continue;
        const auto bin = static_cast<std::size_t>(b);
        sum[bin] += g[p];
        count[bin] += 1.0;
        const std::size_t i = p % static_cast<std::size_t>(d[0]);
        const std::size_t j = p / static_cast<std::size_t>(d[0]) % static_cast<std::size_t>(d[1]);
        const std::size_t k = p / (static_cast<std::size_t>(d[0]) * static_cast<std::size_t>(d[1]));
        const bool onFace = i == 0 || j == 0 || k == 0 || i + 1 == static_cast<std::size_t>(d[0]) ||
                            j + 1 == static_cast<std::size_t>(d[1]) ||
                            k + 1 == static_cast<std::size_t>(d[2]);
        face[bin] += onFace ? 1.0 : 0.0;
        faces += onFace ? 1.0 : 0.0;
    }
    double counted = 0.0;
    for (double c : count) counted += c;
    std::vector<float> sorted = g;
    std::nth_element(sorted.begin(),
                     sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
    const double floor = sorted[sorted.size() / 2];
    // g(v), smoothed over 3 bins; a bin of fewer than 1e-5 of the points counts as empty.
    const double minCount = std::max(1.0, 1e-5 * static_cast<double>(values.size()));
    std::vector<double> mean(kBins, 0.0);
    for (int b = 0; b < kBins; ++b) {
        double s = 0.0, c = 0.0;
        for (int o = std::max(0, b - 1); o <= std::min(kBins - 1, b + 1); ++o)
            if (count[static_cast<std::size_t>(o)] >= minCount)
                s += sum[static_cast<std::size_t>(o)], c += count[static_cast<std::size_t>(o)];
        mean[static_cast<std::size_t>(b)] = c > 0.0 ? s / c : 0.0;
    }
    // What touches the volume's faces much more often than the volume's points do on average is
    // its surroundings (a CT's air, the outside of a simulated object), not the object: values
    // over-represented 2x or more on the faces are left clear, between 1x and 2x fade out.
    std::vector<double> keep(kBins, 1.0);
    const double faceShare = counted > 0.0 ? faces / counted : 0.0;
    for (int b = 0; b < kBins; ++b) {
        const auto bin = static_cast<std::size_t>(b);
        if (count[bin] < minCount || !(faceShare > 0.0)) continue;
        const double over = face[bin] / count[bin] / faceShare;
        keep[bin] = std::clamp(2.0 - over, 0.0, 1.0);
    }
    std::vector<double> weight(kBins, 0.0);
    for (int b = 0; b < kBins; ++b)
        weight[static_cast<std::size_t>(b)] =
            std::max(0.0, mean[static_cast<std::size_t>(b)] - floor) *
            keep[static_cast<std::size_t>(b)];
    const double peak = *std::max_element(weight.begin(), weight.end());
    if (!(peak > 0.0)) return basis;  // no value stands out: the ramp from the median
    basis.rule =
        "boundaries: the mean gradient magnitude per value above the median one (as "
        "Kindlmann & Durkin), clear where a value mostly touches the volume's faces";
    for (int k = 0; k < kPoints; ++k) {
        const double x = lo + (hi - lo) * k / (kPoints - 1);
        const double b = std::clamp((x - lo) / w - 0.5, 0.0, kBins - 1.0);
        const int b0 = static_cast<int>(b), b1 = std::min(b0 + 1, kBins - 1);
        const double m = weight[static_cast<std::size_t>(b0)] * (1.0 - (b - b0)) +
                         weight[static_cast<std::size_t>(b1)] * (b - b0);
        basis.opacityX.push_back(x);
        // Weights under a fifth of the peak are noise (a tail of the air's own values next to
        // an object): clear, or their fog sums up over a long ray.
        basis.opacity.push_back(0.5 * std::clamp((m / peak - kCut) / (1.0 - kCut), 0.0, 1.0));
    }
    return basis;
}

DefaultTfBasis defaultTfBasisOf(const ModelVolume& model) {
    if (model.defaultTf.empty()) return defaultTfBasis(model.grid, model.mean);
    DefaultTfBasis b = decodeDefaultTfBasis(model.defaultTf, "the model");
    if (!b.opacityX.empty()) b.rule = "the full-resolution field's boundaries (recorded by build)";
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
