#include "udvr/classify/model_kind.h"

#include "udvr/classify/model_families.h"
#include "udvr/util/check.h"
#include "udvr/util/text_parse.h"

namespace udvr {

ModelKind parseModelKind(std::string_view name) {
    for (const ModelFamily& f : modelFamilies())
        if (f.name == name) return f.kind;
    std::vector<std::string> names;
    for (const ModelFamily& f : modelFamilies()) names.emplace_back(f.name);
    UDVR_FAIL("unknown model '" << clipForMessage(name) << "'" << didYouMean(name, names)
                                << "; expected one of: " << modelNames());
}

std::string modelNames(bool twoD) {
    std::string all;
    for (const ModelFamily& f : modelFamilies()) {
        if (twoD && !f.makeKernel2D) continue;
        if (!all.empty()) all += ", ";
        all += f.name;
    }
    return all;
}

std::string_view modelName(ModelKind kind) { return modelFamily(kind).name; }

const std::vector<ModelKind>& allModelKinds() {
    static const std::vector<ModelKind> all = [] {
        std::vector<ModelKind> v;
        for (const ModelFamily& f : modelFamilies()) v.push_back(f.kind);
        return v;
    }();
    return all;
}

bool needsQuantiles(ModelKind kind) {
    return (modelFamily(kind).arrays(ClassifyOptions{}) & kArrayQuantiles) != 0;
}

bool readsGmm(ModelKind kind) {
    return (modelFamily(kind).arrays(ClassifyOptions{}) & kArrayGmm) != 0;
}

bool readsMembers(ModelKind kind) {
    return (modelFamily(kind).arrays(ClassifyOptions{}) & kArrayMembers) != 0;
}

bool rendersRealizations(ModelKind kind) { return modelFamily(kind).realizations; }

ModelKind kernelStandIn(ModelKind kind) {
    const ModelFamily& f = modelFamily(kind);
    if (f.makeKernel) return kind;
    for (const ModelFamily& other : modelFamilies())
        if (other.makeKernel && other.arrays(ClassifyOptions{}) == f.arrays(ClassifyOptions{}))
            return other.kind;
    UDVR_FAIL("model '" << f.name
                        << "' has no per-sample kernel, nor a model that reads its arrays");
}

}  // namespace udvr
