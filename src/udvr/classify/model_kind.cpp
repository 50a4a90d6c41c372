#include "udvr/classify/model_kind.h"

#include "udvr/classify/model_families.h"
#include "udvr/util/check.h"
#include "udvr/util/text_parse.h"

namespace udvr {
namespace {

// The names of the rows that `has` (in table order, "mean, uniform, …").
template <class Has>
std::string namesWhere(const Has& has) {
    std::string all;
    for (const ModelFamily& f : modelFamilies()) {
        if (!has(f)) continue;
        if (!all.empty()) all += ", ";
        all += f.name;
    }
    return all;
}

}  // namespace

ModelKind parseModelKind(std::string_view name) {
    for (const ModelRow& r : kModelRows)
        if (r.name == name) return r.kind;
    std::vector<std::string> names;
    for (const ModelRow& r : kModelRows) names.emplace_back(r.name);
    UDVR_FAIL("unknown model '" << clipForMessage(name) << "'" << didYouMean(name, names)
                                << "; expected one of: " << modelNames());
}

std::string modelNames(bool twoD) {
    return namesWhere([&](const ModelFamily& f) { return !twoD || f.makeKernel2D; });
}

std::string modelHelp() {
    // " | " between models: their help phrases hold commas and semicolons.
    std::string help;
    for (const ModelRow& r : kModelRows)
        help += std::string(r.name) + ": " + std::string(r.help) + " | ";
    return help + "with --tf2: " +
           namesWhere([](const ModelFamily& f) { return f.makeKernel2D != nullptr; }) +
           " | with --second: " +
           namesWhere([](const ModelFamily& f) { return f.makeBivariate != nullptr; });
}

std::string_view modelName(ModelKind kind) { return modelRow(kind).name; }

const std::vector<ModelKind>& allModelKinds() {
    static const std::vector<ModelKind> all = [] {
        std::vector<ModelKind> v;
        for (const ModelRow& r : kModelRows) v.push_back(r.kind);
        return v;
    }();
    return all;
}

bool needsQuantiles(ModelKind kind) { return (modelRow(kind).arrays & kArrayQuantiles) != 0; }

bool readsGmm(ModelKind kind) { return (modelRow(kind).arrays & kArrayGmm) != 0; }

bool readsMembers(ModelKind kind) { return (modelRow(kind).arrays & kArrayMembers) != 0; }

bool rendersRealizations(ModelKind kind) { return modelRow(kind).realizations; }

ModelKind kernelStandIn(ModelKind kind) {
    const ModelFamily& f = modelFamily(kind);
    if (f.makeKernel) return kind;
    for (const ModelFamily& other : modelFamilies())
        if (other.makeKernel && other.arrays == f.arrays) return other.kind;
    UDVR_FAIL("model '" << f.name
                        << "' has no per-sample kernel, nor a model that reads its arrays");
}

}  // namespace udvr
