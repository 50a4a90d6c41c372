// Headerless raw fields (raw_io.cpp) with their layout from the input's first bytes:
//   byte 0: bits 0-3 the type name (of kTypes), bit 4 big-endian, bit 5 dims as 3 × int32
//           (else 3 bytes, each 1 + b % 16), bit 6 spacing and origin as 6 doubles;
//   then the dims, the doubles where asked for, and the file's bytes.
#include <array>

#include "checks.h"
#include "fuzz_target.h"
#include "udvr/io/field_io.h"
#include "udvr/io/file_info.h"

namespace {
// RawLayout::type is free text from the command line: the names, their aliases and bad ones.
constexpr const char* kTypes[] = {"uint8",   "int8",    "uint16", "int16", "uint32", "int32",
                                  "float32", "float64", "uchar",  "short", "double", "Float",
                                  "float16", "int64",   "",       "u8"};
}  // namespace

UDVR_FUZZ_TARGET(raw) {
    using namespace udvr;
    const auto flags = fuzz::take<std::uint8_t>(input);
    RawLayout layout;
    layout.type = kTypes[flags & 0x0F];
    layout.bigEndian = (flags & 0x10) != 0;
    for (int a = 0; a < 3; ++a)
        layout.dims[a] = (flags & 0x20) ? fuzz::take<std::int32_t>(input)
                                        : 1 + fuzz::take<std::uint8_t>(input) % 16;
    if (flags & 0x40) {
        for (int a = 0; a < 3; ++a) layout.spacing[a] = fuzz::take<double>(input);
        for (int a = 0; a < 3; ++a) layout.origin[a] = fuzz::take<double>(input);
    }
    const auto path = fuzz::freshFile("field.raw", fuzz::text(input));
    FieldReadOptions options;
    options.raw = layout;
    fuzz::expectCleanResult([&] { fuzz::checkField(readField(path, options), "raw field"); });
    fuzz::expectCleanResult([&] { listArrays(path, layout); });
}
