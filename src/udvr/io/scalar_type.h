#pragma once
// The value types of raw and NRRD files (raw_io.cpp, nrrd_io.cpp; not part of the public API):
// their names and sizes, the quantisation step they give a field, and decoding to float.
#include <cstddef>
#include <string>

#include "udvr/util/field.h"

namespace udvr::detail {

enum class ScalarType { kUint8, kInt8, kUint16, kInt16, kUint32, kInt32, kFloat32, kFloat64 };

/// Bytes of one value of type t.
std::size_t typeSize(ScalarType t);
/// "uint8" … "float64".
const char* typeName(ScalarType t);
/// A field's value type and quantisation step (ScalarField::valueStep): 1 for integer types.
void setValueType(ScalarField& f, ScalarType t);
/// Convert n file values of type t (byte order bigEndian) to float.
void decode(ScalarType t, bool bigEndian, const unsigned char* src, std::size_t n, float* dst);
/// s in lower case (ASCII).
std::string lower(std::string s);

}  // namespace udvr::detail
