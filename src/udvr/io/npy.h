#pragma once
// NumPy .npy headers (format versions 1.0, 2.0 and 3.0): magic "\x93NUMPY", version, header
// length (2 bytes little-endian in 1.0, 4 bytes in 2.0/3.0), then a Python dict literal
// {'descr': '<f4', 'fortran_order': False, 'shape': (H, W, 4), } padded with spaces and '\n',
// then the array data. Only what udvr's readers need: simple dtypes, no pickled objects.
#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

namespace udvr {

/// A little-endian T at p (any alignment).
template <class T>
T loadLittle(const char* p) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, p, sizeof(T));
    if constexpr (std::endian::native == std::endian::big) std::reverse(b, b + sizeof(T));
    T v;
    std::memcpy(&v, b, sizeof(T));
    return v;
}

/// What a .npy header says.
struct NpyHeader {
    int majorVersion = 1;
    std::string descr;             // dtype as written: "<f4", "<f8", "|u1", ">f4", …
    bool fortranOrder = false;     // true: column-major data
    std::vector<long long> shape;  // () for a scalar
    std::size_t dataOffset = 0;    // bytes from the file start to the first data byte

    /// Number of elements (product of the shape; 1 for a scalar).
    std::size_t elementCount() const;
};

/// Parse the header at the start of `bytes`; `what` names the source in errors (UdvrError, one
/// line): bad magic, unknown version, truncated header, a dict that is not a Python literal,
/// missing or mistyped 'descr', 'fortran_order', 'shape', negative dimensions.
NpyHeader parseNpyHeader(std::string_view bytes, const std::string& what);

/// Header bytes for a C-order array of dtype `descr` and `shape`: version 1.0 (2.0 when the
/// dict does not fit 65535 bytes), padded so that the data starts on a 64-byte boundary.
std::string npyHeaderBytes(const std::string& descr, const std::vector<long long>& shape);

}  // namespace udvr
