// The value types of raw and NRRD files: names, sizes, quantisation steps, decoding to float.
#include "udvr/io/scalar_type.h"

#include <algorithm>
#include <bit>
#include <cctype>
#include <cstdint>
#include <cstring>

namespace udvr::detail {
namespace {

template <class T>
void decodeAs(const unsigned char* src, std::size_t n, bool swap, float* dst) {
    unsigned char b[sizeof(T)];
    for (std::size_t i = 0; i < n; ++i) {
        std::memcpy(b, src + i * sizeof(T), sizeof(T));
        if (swap) std::reverse(b, b + sizeof(T));
        T v;
        std::memcpy(&v, b, sizeof(T));
        dst[i] = static_cast<float>(v);
    }
}

}  // namespace

std::size_t typeSize(ScalarType t) {
    switch (t) {
        case ScalarType::kUint8:
        case ScalarType::kInt8:
            return 1;
        case ScalarType::kUint16:
        case ScalarType::kInt16:
            return 2;
        case ScalarType::kUint32:
        case ScalarType::kInt32:
        case ScalarType::kFloat32:
            return 4;
        case ScalarType::kFloat64:
            return 8;
    }
    return 0;
}

const char* typeName(ScalarType t) {
    static const char* const kNames[] = {"uint8",  "int8",  "uint16",  "int16",
                                         "uint32", "int32", "float32", "float64"};
    return kNames[static_cast<int>(t)];
}

/// A field's value type and quantisation step (ScalarField::valueStep): 1 for integer types.
void setValueType(ScalarField& f, ScalarType t) {
    f.valueType = typeName(t);
    f.valueStep = t == ScalarType::kFloat32 || t == ScalarType::kFloat64 ? 0.0 : 1.0;
}

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return s;
}

/// Convert n file values of type t (byte order bigEndian) to float.
void decode(ScalarType t, bool bigEndian, const unsigned char* src, std::size_t n, float* dst) {
    bool swap = bigEndian != (std::endian::native == std::endian::big);
    switch (t) {
        case ScalarType::kUint8:
            return decodeAs<std::uint8_t>(src, n, false, dst);
        case ScalarType::kInt8:
            return decodeAs<std::int8_t>(src, n, false, dst);
        case ScalarType::kUint16:
            return decodeAs<std::uint16_t>(src, n, swap, dst);
        case ScalarType::kInt16:
            return decodeAs<std::int16_t>(src, n, swap, dst);
        case ScalarType::kUint32:
            return decodeAs<std::uint32_t>(src, n, swap, dst);
        case ScalarType::kInt32:
            return decodeAs<std::int32_t>(src, n, swap, dst);
        case ScalarType::kFloat32:
            return decodeAs<float>(src, n, swap, dst);
        case ScalarType::kFloat64:
            return decodeAs<double>(src, n, swap, dst);
    }
}

}  // namespace udvr::detail
