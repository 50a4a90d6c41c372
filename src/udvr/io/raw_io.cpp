// Headerless raw files (SPEC §7): the layout given on the command line, checked against the
// file's size (with a hint at the layout it does fit), read whole or a slab of z-planes at a
// time.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <fstream>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "udvr/io/field_io.h"
#include "udvr/io/io_detail.h"
#include "udvr/io/scalar_type.h"
#include "udvr/util/check.h"

namespace udvr::detail {
namespace fs = std::filesystem;
namespace {

/// Type names of RawLayout (and their C spellings).
std::optional<ScalarType> rawTypeFromName(const std::string& name) {
    std::string n = lower(name);
    if (n == "uint8" || n == "uchar") return ScalarType::kUint8;
    if (n == "int8" || n == "char") return ScalarType::kInt8;
    if (n == "uint16" || n == "ushort") return ScalarType::kUint16;
    if (n == "int16" || n == "short") return ScalarType::kInt16;
    if (n == "uint32" || n == "uint") return ScalarType::kUint32;
    if (n == "int32" || n == "int") return ScalarType::kInt32;
    if (n == "float32" || n == "float") return ScalarType::kFloat32;
    if (n == "float64" || n == "double") return ScalarType::kFloat64;
    return std::nullopt;
}

/// When a raw file's size does not match dims × type, the layout it does fit (a headerless file
/// gives nothing else to go on): cubic dims with the given type, else the given dims with another
/// value size, else cubic dims with another type. Empty when none fits.
std::string rawLayoutHint(const RawLayout& layout, ScalarType type, std::size_t bytes) {
    struct Kind {
        std::size_t size;
        const char* name;
        const char* alternatives;
    };
    static const Kind kKinds[] = {{4, "float32", " (or int32, uint32)"},
                                  {1, "uint8", " (or int8)"},
                                  {2, "uint16", " (or int16)"},
                                  {8, "float64", ""}};
    const std::size_t given = typeSize(type);
    const std::size_t n = static_cast<std::size_t>(layout.dims[0]) *
                          static_cast<std::size_t>(layout.dims[1]) *
                          static_cast<std::size_t>(layout.dims[2]);
    const std::string dims = std::to_string(layout.dims[0]) + "x" + std::to_string(layout.dims[1]) +
                             "x" + std::to_string(layout.dims[2]);
    auto cubeSide = [&](std::size_t valueSize) -> long long {
        if (bytes == 0 || bytes % valueSize != 0) return 0;
        const std::size_t count = bytes / valueSize;
        auto side = static_cast<long long>(std::llround(std::cbrt(static_cast<double>(count))));
        for (long long s = std::max(1LL, side - 1); s <= side + 1; ++s)
            if (static_cast<std::size_t>(s * s * s) == count) return s;
        return 0;
    };
    auto cube = [](long long s) {
        return std::to_string(s) + "x" + std::to_string(s) + "x" + std::to_string(s);
    };
    if (const long long s = cubeSide(given); s > 0)
        return "fits " + layout.type + " " + cube(s) + ": use --dims " + std::to_string(s);
    for (const Kind& k : kKinds)
        if (k.size != given && n * k.size == bytes)
            return std::string("fits ") + k.name + " " + dims + ": use --type " + k.name +
                   k.alternatives;
    for (const Kind& k : kKinds)
        if (k.size != given)
            if (const long long s = cubeSide(k.size); s > 0)
                return std::string("fits ") + k.name + " " + cube(s) + ": use --dims " +
                       std::to_string(s) + " --type " + k.name + k.alternatives;
    return {};
}

/// The type of a raw file's layout, after checking that dims and type are given, the spacing
/// positive and the origin finite (one-line errors naming the file).
ScalarType checkedRawLayout(const fs::path& path, const RawLayout& layout) {
    if (!layout.given()) {
        UDVR_FAIL(path.string() << ": a raw file needs its dims (and type, endianness) given, e.g. "
                                   "--dims 64,64,64 --type float32");
    }
    const auto type = rawTypeFromName(layout.type);
    if (!type) {
        UDVR_FAIL(path.string() << ": unsupported raw type '" << layout.type
                                << "' (expected uint8 int8 uint16 int16 uint32 int32 float32 "
                                   "float64)");
    }
    for (int a = 0; a < 3; ++a) {
        if (!(layout.spacing[a] > 0.0) || !std::isfinite(layout.spacing[a])) {
            UDVR_FAIL(path.string() << ": spacing must be positive, got " << layout.spacing[a]);
        }
        if (!std::isfinite(layout.origin[a]))
            UDVR_FAIL(path.string() << ": origin must be finite, got " << layout.origin[a]);
    }
    return *type;
}

}  // namespace

ScalarField readRaw(const fs::path& path, const RawLayout& layout) {
    const ScalarType type = checkedRawLayout(path, layout);
    ScalarField f;
    f.grid.dims = layout.dims;
    f.grid.spacing = layout.spacing;
    f.grid.origin = layout.origin;
    f.name = path.stem().string();
    checkedDataBytes(path, layout.dims, typeSize(type));
    std::string bytes = readWholeFile(path);
    std::size_t n = f.grid.pointCount();
    if (bytes.size() != n * typeSize(type)) {
        const std::string hint = rawLayoutHint(layout, type, bytes.size());
        if (!hint.empty())
            UDVR_FAIL(path.string()
                      << ": size " << bytes.size() << " bytes does not fit " << layout.dims[0]
                      << "x" << layout.dims[1] << "x" << layout.dims[2] << " " << layout.type
                      << " (" << n * typeSize(type) << " bytes) but " << hint);
    }
    requireByteCount(path, n * typeSize(type), bytes.size(), "raw data");
    f.values.resize(n);
    decode(type, layout.bigEndian, reinterpret_cast<const unsigned char*>(bytes.data()), n,
           f.values.data());
    setValueType(f, type);
    return f;
}

/// A headerless raw file read at the slab's offset.
SlabReader openRawSlabs(const fs::path& path, const RawLayout& layout) {
    const ScalarType type = checkedRawLayout(path, layout);
    SlabReader r;
    r.grid.dims = layout.dims;
    r.grid.spacing = layout.spacing;
    r.grid.origin = layout.origin;
    r.members = 1;
    r.name = path.stem().string();
    const std::size_t ts = typeSize(type);
    checkedDataBytes(path, layout.dims, ts);
    const std::size_t n = r.grid.pointCount();
    const std::size_t size = static_cast<std::size_t>(fs::file_size(path));
    if (size != n * ts) {
        const std::string hint = rawLayoutHint(layout, type, size);
        if (!hint.empty())
            UDVR_FAIL(path.string() << ": size " << size << " bytes does not fit " << layout.dims[0]
                                    << "x" << layout.dims[1] << "x" << layout.dims[2] << " "
                                    << layout.type << " (" << n * ts << " bytes) but " << hint);
    }
    requireByteCount(path, n * ts, size, "raw data");
    ScalarField typed;
    setValueType(typed, type);
    r.valueType = typed.valueType;
    r.valueStep = typed.valueStep;
    const std::size_t plane =
        static_cast<std::size_t>(r.grid.dims[0]) * static_cast<std::size_t>(r.grid.dims[1]);
    r.scratchPerPlane = plane * ts;
    const bool bigEndian = layout.bigEndian;
    r.read = [path, plane, ts, type, bigEndian](int z0, int z1, std::span<float> out) {
        const std::size_t count = static_cast<std::size_t>(z1 - z0) * plane;
        UDVR_CHECK(out.size() == count);
        std::ifstream in(path, std::ios::binary);
        std::vector<unsigned char> bytes(count * ts);
        in.seekg(static_cast<std::streamoff>(static_cast<std::size_t>(z0) * plane * ts));
        in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
        if (!in || static_cast<std::size_t>(in.gcount()) != bytes.size())
            UDVR_FAIL(path.string() << ": cannot read z-planes " << z0 << " to " << z1 - 1
                                    << " (was the file changed while build ran?)");
        decode(type, bigEndian, bytes.data(), count, out.data());
    };
    return r;
}

}  // namespace udvr::detail
