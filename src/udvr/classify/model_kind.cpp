#include "udvr/classify/model_kind.h"

#include <array>
#include <utility>

#include "udvr/util/check.h"

namespace udvr {
namespace {
constexpr std::array<std::pair<ModelKind, std::string_view>, 12> kNames{{
    {ModelKind::Mean, "mean"},
    {ModelKind::Uniform, "uniform"},
    {ModelKind::Gaussian, "gaussian"},
    {ModelKind::GmmOrdered, "gmm-ordered"},
    {ModelKind::GmmMc, "gmm-mc"},
    {ModelKind::QuantileRange, "quantile-range"},
    {ModelKind::QuantileMean, "quantile-mean"},
    {ModelKind::QuantileMeanMass, "quantile-mean-mass"},
    {ModelKind::Iqr, "iqr"},
    {ModelKind::QuartileLower, "quartile-lower"},
    {ModelKind::QuartileMiddle, "quartile-middle"},
    {ModelKind::QuartileUpper, "quartile-upper"},
}};
}  // namespace

ModelKind parseModelKind(std::string_view name) {
    for (const auto& [kind, n] : kNames)
        if (n == name) return kind;
    std::string all;
    for (const auto& [kind, n] : kNames) {
        if (!all.empty()) all += ", ";
        all += n;
    }
    UDVR_FAIL("unknown model '" << name << "'; expected one of: " << all);
}

std::string_view modelName(ModelKind kind) {
    for (const auto& [k, n] : kNames)
        if (k == kind) return n;
    return "?";
}

const std::vector<ModelKind>& allModelKinds() {
    static const std::vector<ModelKind> all = [] {
        std::vector<ModelKind> v;
        for (const auto& [k, n] : kNames) v.push_back(k);
        return v;
    }();
    return all;
}

bool needsQuantiles(ModelKind kind) {
    switch (kind) {
        case ModelKind::QuantileRange:
        case ModelKind::QuantileMean:
        case ModelKind::QuantileMeanMass:
        case ModelKind::QuartileLower:
        case ModelKind::QuartileMiddle:
        case ModelKind::QuartileUpper:
            return true;
        default:
            return false;
    }
}

}  // namespace udvr
