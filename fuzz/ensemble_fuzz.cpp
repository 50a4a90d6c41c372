// Ensembles from member files (ensemble_io.cpp): up to 6 members split at kPartSeparator, all
// of one format, given as a list or as a glob pattern. Byte 0 of the input:
//   bits 0-1 the members' format (NRRD, VTI, raw, NetCDF), bit 2 voxel-major storage, bit 3 a
//   glob pattern instead of the list, bit 4 raw members as uint8 (else float32);
//   raw members take their dims from bytes 1-3 (1 + b % 8 each).
#include "checks.h"
#include "fuzz_target.h"
#include "udvr/io/ensemble_io.h"
#include "udvr/io/io_detail.h"

UDVR_FUZZ_TARGET(ensemble) {
    using namespace udvr;
    // A damaged NetCDF-4 file on which HDF5 never returns costs 0.1 s, not 10.
    static const bool quickProbe = (detail::setHdf5ProbeSeconds(0.1), true);
    (void)quickProbe;
    const auto flags = fuzz::take<std::uint8_t>(input);
    static const char* const kExtensions[] = {".nrrd", ".vti", ".raw", ".nc"};
    const std::string ext = kExtensions[flags & 3];
    EnsembleReadOptions options;
    options.voxelMajor = (flags & 4) != 0;
    if (ext == ".raw") {
        options.raw.type = (flags & 16) ? "uint8" : "float32";
        for (int a = 0; a < 3; ++a) options.raw.dims[a] = 1 + fuzz::take<std::uint8_t>(input) % 8;
    }
    auto& scratch = fuzz::Scratch::get();
    scratch.clear();
    std::vector<std::string> inputs;
    const std::vector<std::string> parts = fuzz::splitParts(input, 6);
    for (std::size_t m = 0; m < parts.size(); ++m)
        inputs.push_back(scratch.write("member_" + std::to_string(m) + ext, parts[m]).string());
    if (flags & 8) inputs = {(scratch.dir() / ("member_*" + ext)).string()};
    fuzz::expectCleanResult(
        [&] { fuzz::checkEnsemble(readEnsemble(inputs, options), "member ensemble"); });
}
