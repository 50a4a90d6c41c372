// What the two drivers of `udvr build` share (build_steps.h).
#include "udvr/cmd/build_steps.h"

#include <algorithm>
#include <chrono>
#include <limits>
#include <string>
#include <vector>

#include "udvr/util/check.h"
#include "udvr/util/memory.h"

namespace udvr::cmd {

double secondsSince(std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

void fitOptionsToSamples(BuildOptions& opt, long long samples, bool gmmGiven, bool quantilesGiven,
                         std::string& notes) {
    const BuildFitNotes fit = fitBuildOptionsToSamples(opt, samples, gmmGiven, quantilesGiven);
    for (const std::string& w : fit.warnings) notes += "udvr: warning: " + w + "\n";
    if (!fit.info.empty())
        notes += "build: " + std::to_string(std::min<long long>(samples, 1 << 30)) +
                 " samples per voxel: " + fit.info + "\n";
}

MemoryLimit parseMemoryLimit(const std::string& value) {
    MemoryLimit m;
    if (value == "auto") {
        const MemoryHeadroom h = memoryHeadroom();
        // Half: room for the page cache the reads go through, and for other processes.
        m.bytes = h.bytes > 0 ? h.bytes / 2 : std::numeric_limits<std::size_t>::max() / 4;
        m.text = byteSizeText(m.bytes) + " (auto: half of " +
                 (h.bytes > 0 ? byteSizeText(h.bytes) + " of " + h.source : "unknown memory") + ")";
    } else {
        m.bytes = parseByteSize(value, "--memory-limit");
        m.text = value;
    }
    return m;
}

int planSlabs(const BuildMemory& mem, const MemoryLimit& limit, int modelZ, int k, int forced,
              const std::string& what) {
    if (forced > 0) return std::max(forced / std::max(k, 1), 1);
    const int planes = mem.planesWithin(limit.bytes);
    if (planes >= modelZ) return 0;
    if (planes == 0)
        UDVR_FAIL("--memory-limit " << limit.text << " is too small for this build: a slab of "
                                    << (k > 1 ? std::to_string(k) + " z-planes (one brick)"
                                              : std::string("one z-plane"))
                                    << " of " << what << " needs about "
                                    << byteSizeText(mem.fixed + mem.perPlane)
                                    << "; give at least that (more for fewer, thicker slabs)");
    return planes;
}

SlabInput slabInputOf(const SlabReader& r) {
    return SlabInput{r.grid, r.members, r.valueStep, r.valueType, r.read};
}

SlabReader openBrickedField(const std::vector<std::string>& inputs, const FieldReadOptions& ro) {
    if (inputs.size() != 1)
        UDVR_FAIL("--downsample takes one field, got " << inputs.size() << " inputs");
    try {
        return openFieldSlabs(inputs[0], ro);
    } catch (const EnsembleNotFieldError& e) {
        UDVR_FAIL(e.file << " holds a " << e.members << "-member ensemble (variable '" << e.var
                         << "', dims " << e.dims
                         << "): --downsample reduces one field; drop --downsample to build the "
                            "model from the "
                         << e.members << " members");
    }
}

void requireEnsembleInputs(const std::vector<std::string>& inputs) {
    const std::string& first = inputs[0];
    if (inputs.size() == 1 && first.find_first_of("*?[") == std::string::npos &&
        lowerExtension(first) != ".nc")
        UDVR_FAIL(first << " is one field: --downsample K models its K^3 bricks; an ensemble is "
                           "a NetCDF variable with a member dimension or 2+ member files");
}

}  // namespace udvr::cmd
