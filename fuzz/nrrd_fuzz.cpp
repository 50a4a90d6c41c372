// NRRD (nrrd_io.cpp): the input is the header with attached data (raw, gzip or ascii), or a
// detached header, kPartSeparator, and the data file it names ("data file: data.raw").
#include "checks.h"
#include "fuzz_target.h"
#include "udvr/io/field_io.h"
#include "udvr/io/file_info.h"

UDVR_FUZZ_TARGET(nrrd) {
    using namespace udvr;
    const std::vector<std::string> parts = fuzz::splitParts(input, 2);
    auto& scratch = fuzz::Scratch::get();
    scratch.clear();
    const bool detached = parts.size() == 2;
    const auto path = scratch.write(detached ? "field.nhdr" : "field.nrrd", parts[0]);
    if (detached) scratch.write("data.raw", parts[1]);
    fuzz::expectCleanResult([&] { fuzz::checkField(readField(path), "NRRD field"); });
    // `udvr info` reads the header only.
    fuzz::expectCleanResult([&] { listArrays(path); });
}
