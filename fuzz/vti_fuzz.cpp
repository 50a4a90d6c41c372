// VTK XML ImageData fields (vti_io.cpp): appended raw or compressed (zlib, LZ4) data, inline
// base64, ascii; what `udvr info` lists and what `udvr build`/`render` read as a field.
#include "checks.h"
#include "fuzz_target.h"
#include "udvr/io/field_io.h"
#include "udvr/io/file_info.h"

UDVR_FUZZ_TARGET(vti) {
    using namespace udvr;
    const auto path = fuzz::freshFile("field.vti", fuzz::text(input));
    fuzz::expectCleanResult([&] { fuzz::checkField(readField(path), "VTI field"); });
    fuzz::expectCleanResult([&] { listArrays(path); });
}
