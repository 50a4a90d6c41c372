// Field readers for raw and NRRD files, the format dispatch, and the checks every reader shares.
// VTK (.vti) and NetCDF (.nc) live in vti_io.cpp and netcdf_io.cpp.
#include "udvr/io/field_io.h"

#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>
#include <optional>
#include <sstream>
#include <vector>

#include "udvr/io/io_detail.h"
#include "udvr/util/check.h"

namespace udvr {
namespace fs = std::filesystem;

namespace detail {

void checkFinite(const fs::path& path, const Grid3& grid, std::span<const float> values,
                 int components, const std::string& what) {
    std::size_t nans = 0, infs = 0, first = 0;
    for (std::size_t i = 0; i < values.size(); ++i) {
        float v = values[i];
        if (std::isfinite(v)) continue;
        if (nans + infs == 0) first = i;
        if (std::isnan(v)) {
            ++nans;
        } else {
            ++infs;
        }
    }
    if (nans + infs == 0) return;
    std::size_t voxel = first / static_cast<std::size_t>(components);
    std::size_t nx = static_cast<std::size_t>(std::max(grid.dims[0], 1));
    std::size_t ny = static_cast<std::size_t>(std::max(grid.dims[1], 1));
    UDVR_FAIL(path.string() << ": " << nans << " NaN and " << infs << " Inf values"
                            << (what.empty() ? "" : " in ") << what << ", the first at (i,j,k) = ("
                            << voxel % nx << "," << (voxel / nx) % ny << "," << voxel / (nx * ny)
                            << "); expected finite values");
}

void requireFile(const fs::path& path) {
    std::error_code ec;
    auto status = fs::status(path, ec);
    if (!fs::exists(status)) UDVR_FILE_FAIL("cannot read " << path.string() << ": no such file");
    if (!fs::is_regular_file(status)) {
        UDVR_FILE_FAIL("cannot read " << path.string() << ": not a regular file");
    }
}

std::string lowerExtension(const fs::path& path) {
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return ext;
}

/// Points × bytes per value of a grid, failing where that cannot be a file udvr can hold (it
/// would not fit in memory, or the product overflows).
std::size_t checkedDataBytes(const fs::path& path, const std::array<int, 3>& dims,
                             std::size_t valueSize) {
    long double bytes = static_cast<long double>(valueSize);
    for (int d : dims) bytes *= static_cast<long double>(d);
    if (bytes > static_cast<long double>(std::size_t{1} << 56))
        UDVR_FAIL(path.string() << ": dims " << dims[0] << "x" << dims[1] << "x" << dims[2]
                                << " are too large (" << static_cast<double>(bytes)
                                << " bytes of data)");
    return static_cast<std::size_t>(bytes);
}

}  // namespace detail

fs::path singleFileOf(const fs::path& path) {
    const std::string text = path.string();
    std::error_code ec;
    if (!detail::isGlobPattern(text) || fs::exists(path, ec)) return path;
    const std::vector<std::string> matches = detail::expandGlob(text);  // none: an error
    if (matches.size() == 1) return matches.front();
    UDVR_FAIL("pattern '" << text << "' matches " << matches.size() << " files (" << matches[0]
                          << ", " << matches[1] << (matches.size() > 2 ? ", ..." : "")
                          << ") where one field or model is read; an ensemble of them is built "
                             "with `udvr build` or rendered with --model members");
}

std::vector<std::string> withOneMatchResolved(const std::vector<std::string>& inputs) {
    std::error_code ec;
    if (inputs.size() != 1 || !detail::isGlobPattern(inputs[0]) || fs::exists(inputs[0], ec))
        return inputs;
    const std::vector<std::string> matches = detail::expandGlob(inputs[0]);
    return matches.size() == 1 ? matches : inputs;
}

namespace {

enum class ScalarType { kUint8, kInt8, kUint16, kInt16, kUint32, kInt32, kFloat32, kFloat64 };

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

std::string trim(const std::string& s) {
    std::size_t b = s.find_first_not_of(" \t\r\n");
    if (b == std::string::npos) return "";
    std::size_t e = s.find_last_not_of(" \t\r\n");
    return s.substr(b, e - b + 1);
}

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

/// NRRD type names (NRRD0005 spec, all spellings), minus the 64-bit integers and "block".
std::optional<ScalarType> nrrdTypeFromName(const std::string& name) {
    static const std::pair<const char*, ScalarType> kNames[] = {
        {"signed char", ScalarType::kInt8},
        {"int8", ScalarType::kInt8},
        {"int8_t", ScalarType::kInt8},
        {"uchar", ScalarType::kUint8},
        {"unsigned char", ScalarType::kUint8},
        {"uint8", ScalarType::kUint8},
        {"uint8_t", ScalarType::kUint8},
        {"short", ScalarType::kInt16},
        {"short int", ScalarType::kInt16},
        {"signed short", ScalarType::kInt16},
        {"signed short int", ScalarType::kInt16},
        {"int16", ScalarType::kInt16},
        {"int16_t", ScalarType::kInt16},
        {"ushort", ScalarType::kUint16},
        {"unsigned short", ScalarType::kUint16},
        {"unsigned short int", ScalarType::kUint16},
        {"uint16", ScalarType::kUint16},
        {"uint16_t", ScalarType::kUint16},
        {"int", ScalarType::kInt32},
        {"signed int", ScalarType::kInt32},
        {"int32", ScalarType::kInt32},
        {"int32_t", ScalarType::kInt32},
        {"uint", ScalarType::kUint32},
        {"unsigned int", ScalarType::kUint32},
        {"uint32", ScalarType::kUint32},
        {"uint32_t", ScalarType::kUint32},
        {"float", ScalarType::kFloat32},
        {"double", ScalarType::kFloat64},
    };
    std::string n = lower(name);
    for (const auto& [s, t] : kNames) {
        if (n == s) return t;
    }
    return std::nullopt;
}

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

std::string readWholeFile(const fs::path& path) {
    detail::requireFile(path);
    std::ifstream in(path, std::ios::binary);
    if (!in) UDVR_FILE_FAIL("cannot open " << path.string());
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) UDVR_FILE_FAIL("cannot read " << path.string() << ": I/O error");
    return bytes;
}

/// `data` must hold exactly `expected` bytes (what the dims and type ask for).
void requireByteCount(const fs::path& path, std::size_t expected, std::size_t actual,
                      const std::string& what) {
    if (actual < expected) {
        UDVR_FAIL(path.string() << ": truncated " << what << ": expected " << expected
                                << " bytes, found " << actual);
    }
    if (actual > expected) {
        UDVR_FAIL(path.string() << ": dims do not match the " << what << " size: expected "
                                << expected << " bytes, found " << actual);
    }
}

// ---- raw ---------------------------------------------------------------------------------------

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

ScalarField readRaw(const fs::path& path, const RawLayout& layout) {
    const ScalarType type = checkedRawLayout(path, layout);
    ScalarField f;
    f.grid.dims = layout.dims;
    f.grid.spacing = layout.spacing;
    f.grid.origin = layout.origin;
    f.name = path.stem().string();
    detail::checkedDataBytes(path, layout.dims, typeSize(type));
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

// ---- NRRD --------------------------------------------------------------------------------------

struct NrrdHeader {
    std::optional<ScalarType> type;
    std::string typeName;
    int dimension = 0;
    std::vector<long long> sizes;
    std::vector<double> spacings;
    std::vector<std::array<double, 3>> directions;  // empty, or one per axis ("none" skipped)
    std::optional<std::array<double, 3>> spaceOrigin;
    std::string endian;
    std::string encoding;
    std::string dataFile;
    long long lineSkip = 0;
    long long byteSkip = 0;
    std::string content;
    std::size_t dataOffset = std::string::npos;  // attached data: offset after the blank line
};

[[noreturn]] void nrrdFail(const fs::path& path, int line, const std::string& message) {
    UDVR_FAIL(path.string() << ": NRRD header line " << line << ": " << message);
}

std::vector<std::string> splitWords(const std::string& s) {
    std::istringstream is(s);
    std::vector<std::string> words;
    for (std::string w; is >> w;) words.push_back(w);
    return words;
}

double parseDouble(const fs::path& path, int line, const std::string& word) {
    std::string w = lower(word);
    if (w == "nan") return std::nan("");
    try {
        std::size_t used = 0;
        double v = std::stod(word, &used);
        if (used == word.size()) return v;
    } catch (const std::exception&) {
    }
    nrrdFail(path, line, "'" + word + "' is not a number");
}

long long parseInteger(const fs::path& path, int line, const std::string& word) {
    try {
        std::size_t used = 0;
        long long v = std::stoll(word, &used);
        if (used == word.size()) return v;
    } catch (const std::exception&) {
    }
    nrrdFail(path, line, "'" + word + "' is not an integer");
}

/// "(a,b,c)" → {a,b,c}.
std::array<double, 3> parseVector(const fs::path& path, int line, const std::string& text) {
    std::string t = trim(text);
    if (t.size() < 2 || t.front() != '(' || t.back() != ')') {
        nrrdFail(path, line, "expected a vector '(x,y,z)', got '" + t + "'");
    }
    std::string inner = t.substr(1, t.size() - 2);
    std::replace(inner.begin(), inner.end(), ',', ' ');
    auto words = splitWords(inner);
    if (words.size() != 3) nrrdFail(path, line, "expected 3 components in '" + t + "'");
    return {parseDouble(path, line, words[0]), parseDouble(path, line, words[1]),
            parseDouble(path, line, words[2])};
}

void parseNrrdField(const fs::path& path, int line, const std::string& key,
                    const std::string& value, NrrdHeader& h) {
    static const char* const kIgnored[] = {"kinds",        "centers",     "centerings",
                                           "labels",       "units",       "space units",
                                           "min",          "max",         "old min",
                                           "oldmin",       "old max",     "oldmax",
                                           "axis mins",    "axismins",    "axis maxs",
                                           "axismaxs",     "thicknesses", "measurement frame",
                                           "sample units", "sampleunits", "number",
                                           "block size",   "blocksize",   "space"};
    if (key == "type") {
        h.typeName = value;
        h.type = nrrdTypeFromName(value);
        if (!h.type) {
            nrrdFail(path, line,
                     "unsupported type '" + value +
                         "' (expected uint8 int8 uint16 int16 uint32 int32 float double)");
        }
    } else if (key == "dimension") {
        h.dimension = static_cast<int>(parseInteger(path, line, value));
        if (h.dimension != 3) {
            nrrdFail(path, line, "dimension " + value + " is not supported (expected 3)");
        }
    } else if (key == "sizes") {
        for (const auto& w : splitWords(value)) h.sizes.push_back(parseInteger(path, line, w));
    } else if (key == "spacings") {
        for (const auto& w : splitWords(value)) h.spacings.push_back(parseDouble(path, line, w));
    } else if (key == "space directions") {
        // Vectors are written without spaces inside the parentheses; "none" marks a
        // non-spatial axis, which a 3D scalar field does not have.
        for (const auto& w : splitWords(value)) {
            if (lower(w) == "none") nrrdFail(path, line, "'none' space direction: not a 3D grid");
            h.directions.push_back(parseVector(path, line, w));
        }
    } else if (key == "space origin") {
        h.spaceOrigin = parseVector(path, line, value);
    } else if (key == "space dimension") {
        if (parseInteger(path, line, value) != 3) {
            nrrdFail(path, line, "space dimension " + value + " is not supported (expected 3)");
        }
    } else if (key == "endian") {
        h.endian = lower(value);
        if (h.endian != "little" && h.endian != "big") {
            nrrdFail(path, line, "endian '" + value + "' (expected little or big)");
        }
    } else if (key == "encoding") {
        h.encoding = lower(value);
        if (h.encoding == "gz") h.encoding = "gzip";
        if (h.encoding == "text" || h.encoding == "txt") h.encoding = "ascii";
        if (h.encoding != "raw" && h.encoding != "gzip" && h.encoding != "ascii") {
            nrrdFail(path, line,
                     "unsupported encoding '" + value + "' (expected raw, gzip or ascii)");
        }
    } else if (key == "data file" || key == "datafile") {
        h.dataFile = value;
        if (splitWords(value).size() != 1 || lower(value).rfind("list", 0) == 0) {
            nrrdFail(path, line, "multi-file data ('" + value + "') is not supported");
        }
    } else if (key == "line skip" || key == "lineskip") {
        h.lineSkip = parseInteger(path, line, value);
        if (h.lineSkip < 0) nrrdFail(path, line, "negative line skip");
    } else if (key == "byte skip" || key == "byteskip") {
        h.byteSkip = parseInteger(path, line, value);
        if (h.byteSkip < -1) nrrdFail(path, line, "byte skip below -1");
    } else if (key == "content") {
        h.content = value;
    } else if (std::find(std::begin(kIgnored), std::end(kIgnored), key) == std::end(kIgnored)) {
        nrrdFail(path, line, "unknown field '" + key + "'");
    }
}

NrrdHeader parseNrrdHeader(const fs::path& path, const std::string& text) {
    NrrdHeader h;
    std::size_t pos = 0;
    int lineNo = 0;
    bool ended = false;
    while (pos < text.size()) {
        std::size_t eol = text.find('\n', pos);
        std::size_t next = eol == std::string::npos ? text.size() : eol + 1;
        std::string line = text.substr(pos, (eol == std::string::npos ? text.size() : eol) - pos);
        if (!line.empty() && line.back() == '\r') line.pop_back();
        pos = next;
        ++lineNo;
        if (lineNo == 1) {
            if (line.rfind("NRRD000", 0) != 0) {
                UDVR_FAIL(path.string() << ": not a NRRD file (first line '" << line.substr(0, 40)
                                        << "', expected NRRD0001..NRRD0005)");
            }
            continue;
        }
        if (line.empty()) {
            ended = true;
            break;
        }
        if (line[0] == '#') continue;
        std::size_t colon = line.find(": ");
        std::size_t kv = line.find(":=");
        if (kv != std::string::npos && (colon == std::string::npos || kv < colon)) continue;
        if (colon == std::string::npos) {
            nrrdFail(path, lineNo, "expected 'field: value', got '" + line + "'");
        }
        parseNrrdField(path, lineNo, lower(trim(line.substr(0, colon))),
                       trim(line.substr(colon + 2)), h);
    }
    if (ended) h.dataOffset = pos;
    if (lineNo == 0) UDVR_FAIL(path.string() << ": empty file, expected a NRRD header");
    if (!h.type) UDVR_FAIL(path.string() << ": NRRD header has no 'type' field");
    if (h.dimension == 0) UDVR_FAIL(path.string() << ": NRRD header has no 'dimension' field");
    if (h.encoding.empty()) UDVR_FAIL(path.string() << ": NRRD header has no 'encoding' field");
    if (h.sizes.size() != 3) {
        UDVR_FAIL(path.string() << ": NRRD 'sizes' must hold 3 values, found " << h.sizes.size());
    }
    for (long long s : h.sizes) {
        if (s < 1 || s > INT_MAX) UDVR_FAIL(path.string() << ": NRRD size " << s << " is invalid");
    }
    if (!h.spacings.empty() && h.spacings.size() != 3) {
        UDVR_FAIL(path.string() << ": NRRD 'spacings' must hold 3 values, found "
                                << h.spacings.size());
    }
    if (!h.directions.empty() && h.directions.size() != 3) {
        UDVR_FAIL(path.string() << ": NRRD 'space directions' must hold 3 vectors, found "
                                << h.directions.size());
    }
    if (typeSize(*h.type) > 1 && h.encoding != "ascii" && h.endian.empty()) {
        UDVR_FAIL(path.string() << ": NRRD header has no 'endian' field, needed for type '"
                                << h.typeName << "'");
    }
    return h;
}

/// Grid geometry from spacings or space directions/origin. A rotated or flipped frame cannot be
/// held by Grid3; its axis lengths are kept and *note (when given) says the orientation is lost,
/// for the caller to print once the whole read succeeded.
Grid3 nrrdGrid(const fs::path& path, const NrrdHeader& h, std::string* note) {
    Grid3 g;
    for (int a = 0; a < 3; ++a) g.dims[a] = static_cast<int>(h.sizes[a]);
    if (!h.directions.empty()) {
        bool aligned = true;
        for (int a = 0; a < 3; ++a) {
            const auto& d = h.directions[a];
            g.spacing[a] = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            for (int b = 0; b < 3; ++b) {
                if ((b == a && !(d[b] > 0.0)) || (b != a && d[b] != 0.0)) aligned = false;
            }
        }
        if (!aligned && note != nullptr) {
            *note = "udvr: note: " + path.string() +
                    ": space directions are not the positive x,y,z axes; keeping their lengths "
                    "as spacing and ignoring the orientation";
        }
    } else if (!h.spacings.empty()) {
        for (int a = 0; a < 3; ++a) g.spacing[a] = std::isnan(h.spacings[a]) ? 1.0 : h.spacings[a];
    }
    if (h.spaceOrigin) g.origin = *h.spaceOrigin;
    for (int a = 0; a < 3; ++a) {
        if (!(g.spacing[a] > 0.0) || !std::isfinite(g.spacing[a])) {
            UDVR_FAIL(path.string() << ": NRRD spacing along axis " << a << " is " << g.spacing[a]
                                    << ", expected a positive number");
        }
        if (!std::isfinite(g.origin[a])) {
            UDVR_FAIL(path.string() << ": NRRD space origin is not finite");
        }
    }
    return g;
}

/// Skip `lines` newline-terminated lines from `offset`.
std::size_t skipLines(const fs::path& path, const std::string& bytes, std::size_t offset,
                      long long lines) {
    for (long long l = 0; l < lines; ++l) {
        std::size_t eol = bytes.find('\n', offset);
        if (eol == std::string::npos) {
            UDVR_FAIL(path.string() << ": truncated data: cannot skip " << lines << " lines");
        }
        offset = eol + 1;
    }
    return offset;
}

/// Inflate a gzip (or zlib) stream; stops once more than `limit` bytes have come out.
std::string gunzip(const fs::path& path, const char* data, std::size_t size, std::size_t limit) {
    z_stream zs{};
    if (inflateInit2(&zs, 15 + 32) != Z_OK) UDVR_FAIL("zlib: inflateInit2 failed");
    std::string out;
    // Deflate expands at most ~1032:1: a header cannot make a small file reserve gigabytes.
    out.reserve(std::min(limit, size * 1032 + (1u << 16)));
    std::vector<unsigned char> buf(1 << 16);
    std::size_t consumed = 0;
    bool complete = false;
    while (out.size() <= limit) {
        if (zs.avail_in == 0 && consumed < size) {
            std::size_t chunk = std::min<std::size_t>(size - consumed, 1u << 30);
            zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data + consumed));
            zs.avail_in = static_cast<uInt>(chunk);
            consumed += chunk;
        }
        zs.next_out = buf.data();
        zs.avail_out = static_cast<uInt>(buf.size());
        int ret = inflate(&zs, Z_NO_FLUSH);
        out.append(reinterpret_cast<const char*>(buf.data()), buf.size() - zs.avail_out);
        if (ret == Z_STREAM_END) {
            complete = true;
            // Another gzip member may follow (concatenated streams); trailing whitespace may not
            // be one, as some writers end attached data with a newline.
            std::size_t rest = size - consumed + zs.avail_in;
            const char* restBegin = data + (size - rest);
            if (std::all_of(restBegin, data + size,
                            [](char c) { return std::isspace(static_cast<unsigned char>(c)); })) {
                break;
            }
            inflateReset(&zs);
            continue;
        }
        if (ret == Z_BUF_ERROR && zs.avail_in == 0 && consumed == size) {
            complete = false;
            break;
        }
        if (ret != Z_OK && ret != Z_BUF_ERROR) {
            std::string msg = zs.msg ? zs.msg : "unknown error";
            inflateEnd(&zs);
            UDVR_FAIL(path.string() << ": corrupt gzip data (" << msg << ")");
        }
        complete = false;
    }
    inflateEnd(&zs);
    if (!complete && out.size() < limit) {
        UDVR_FAIL(path.string() << ": truncated gzip data: expected " << limit
                                << " bytes after decompression, got " << out.size());
    }
    return out;
}

std::vector<float> parseAscii(const fs::path& path, const std::string& text, std::size_t n) {
    std::vector<float> values;
    values.reserve(std::min(n, text.size() / 2 + 1));  // a value and a separator at least
    const char* p = text.c_str();
    const char* end = p + text.size();
    while (p < end) {
        while (p < end && (std::isspace(static_cast<unsigned char>(*p)) || *p == ',')) ++p;
        if (p >= end) break;
        char* stop = nullptr;
        double v = std::strtod(p, &stop);
        if (stop == p) {
            UDVR_FAIL(path.string()
                      << ": ascii data value " << values.size() << " is not a number");
        }
        values.push_back(static_cast<float>(v));
        p = stop;
    }
    if (values.size() < n) {
        UDVR_FAIL(path.string() << ": truncated ascii data: expected " << n << " values, found "
                                << values.size());
    }
    if (values.size() > n) {
        UDVR_FAIL(path.string() << ": dims do not match the ascii data: expected " << n
                                << " values, found " << values.size());
    }
    return values;
}

ScalarField readNrrd(const fs::path& path, std::string* note) {
    std::string headerBytes = readWholeFile(path);
    NrrdHeader h = parseNrrdHeader(path, headerBytes);
    ScalarField f;
    f.grid = nrrdGrid(path, h, note);
    f.name = h.content.empty() ? path.stem().string() : h.content;

    // The data: a detached file, or what follows the blank line.
    std::string detachedBytes;
    const std::string* bytes = &headerBytes;
    fs::path dataPath = path;
    std::size_t offset = h.dataOffset;
    if (!h.dataFile.empty()) {
        dataPath = fs::path(h.dataFile).is_absolute() ? fs::path(h.dataFile)
                                                      : path.parent_path() / h.dataFile;
        std::error_code ec;
        if (!fs::is_regular_file(dataPath, ec)) {
            UDVR_FAIL(path.string() << ": data file '" << h.dataFile << "' not found (looked for "
                                    << dataPath.string() << ")");
        }
        detachedBytes = readWholeFile(dataPath);
        bytes = &detachedBytes;
        offset = 0;
    } else if (offset == std::string::npos) {
        UDVR_FAIL(path.string() << ": NRRD header has no 'data file' field and no attached data "
                                   "after a blank line");
    }
    offset = skipLines(dataPath, *bytes, offset, h.lineSkip);

    std::size_t n = f.grid.pointCount();
    std::size_t expected = detail::checkedDataBytes(path, f.grid.dims, typeSize(*h.type));
    bool big = h.endian == "big";
    if (h.encoding == "ascii") {
        f.values = parseAscii(dataPath, bytes->substr(offset), n);
    } else {
        std::string inflated;
        const char* data = bytes->data() + offset;
        std::size_t size = bytes->size() - offset;
        if (h.encoding == "gzip") {
            std::size_t skip = h.byteSkip > 0 ? static_cast<std::size_t>(h.byteSkip) : 0;
            inflated = gunzip(dataPath, data, size, expected + skip);
            data = inflated.data() + std::min(skip, inflated.size());
            size = inflated.size() - std::min(skip, inflated.size());
            requireByteCount(dataPath, expected, size, "gzip data (after decompression)");
        } else {
            if (h.byteSkip == -1) {
                // The data are the last `expected` bytes of the file.
                if (size < expected) requireByteCount(dataPath, expected, size, "raw data");
                data += size - expected;
                size = expected;
            } else {
                std::size_t skip = static_cast<std::size_t>(h.byteSkip);
                if (skip > size) {
                    requireByteCount(dataPath, expected + skip, size, "raw data (with byte skip)");
                }
                data += skip;
                size -= skip;
            }
            requireByteCount(dataPath, expected, size, "raw data");
        }
        f.values.resize(n);
        decode(*h.type, big, reinterpret_cast<const unsigned char*>(data), n, f.values.data());
    }
    setValueType(f, *h.type);
    return f;
}

}  // namespace

namespace detail {

std::string nrrdTypeName(const fs::path& path) {
    // The header only: the lines up to the first empty one (attached data is not read).
    std::ifstream in(path, std::ios::binary);
    if (!in) UDVR_FILE_FAIL("cannot open " << path.string());
    std::string header, line;
    while (std::getline(in, line)) {
        header += line + "\n";
        if (line.empty() || line == "\r") break;
    }
    const NrrdHeader h = parseNrrdHeader(path, header);
    if (!h.type) return h.typeName;
    return typeName(*h.type);
}

void printNote(const std::string& note) {
    if (!note.empty()) std::fprintf(stderr, "%s\n", note.c_str());
}

ScalarField readFieldImpl(const fs::path& given, const FieldReadOptions& options,
                          std::string* geometryNote) {
    const fs::path path = singleFileOf(given);
    requireFile(path);
    std::string ext = lowerExtension(path);
    ScalarField f;
    if (ext == ".nrrd" || ext == ".nhdr") {
        f = readNrrd(path, geometryNote);
    } else if (ext == ".vti" || ext == ".pvti") {
        f = readFieldVti(path, options.var, geometryNote);
    } else if (ext == ".nc" || ext == ".nc4" || ext == ".cdf") {
        f = readFieldNetcdf(path, options.var, geometryNote, options.allowMissing);
    } else if (ext == ".raw" || options.raw.given()) {
        f = readRaw(path, options.raw);
    } else {
        UDVR_FAIL("cannot read " << path.string() << ": unknown field format '" << ext
                                 << "' (expected .raw .nrrd .nhdr .vti .pvti .nc)");
    }
    // Every format's origin and spacing are finite; their far corner must be too (an origin of
    // 1.7e308 and a spacing of 1e308 put it at Inf).
    const std::array<double, 6> box = f.grid.bounds();
    for (double b : box)
        if (!std::isfinite(b))
            UDVR_FAIL(path.string() << ": the grid's origin and spacing put its far corner beyond "
                                       "the largest number");
    if (!options.allowMissing) checkFinite(path, f.grid, f.values);
    return f;
}

}  // namespace detail

ScalarField readField(const fs::path& path, const FieldReadOptions& options) {
    std::string note;
    ScalarField f = detail::readFieldImpl(path, options, &note);
    detail::printNote(note);
    return f;
}

void writeField(const fs::path& path, const ScalarField& field) {
    std::string ext = detail::lowerExtension(path);
    if (ext == ".vti") return writeFieldVti(path, field);
    if (ext == ".nc") return writeFieldNetcdf(path, field);
    UDVR_FAIL("cannot write " << path.string() << ": unknown field format '" << ext
                              << "' (expected .vti or .nc)");
}

// ---- slabs of z-planes (out-of-core build) -----------------------------------------------------

namespace {

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
    detail::checkedDataBytes(path, layout.dims, ts);
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

/// Any field format, read whole for every slab and the slab's planes kept (VTI, NRRD). The read
/// that opens it serves the first slab.
SlabReader openWholeSlabs(const fs::path& path, const FieldReadOptions& options) {
    FieldReadOptions o = options;
    o.allowMissing = true;  // build's scan reports NaN/Inf
    SlabReader r;
    auto opened = std::make_shared<ScalarField>(detail::readFieldImpl(path, o, &r.note));
    r.grid = opened->grid;
    r.name = opened->name;
    r.valueType = opened->valueType;
    r.valueStep = opened->valueStep;
    r.members = 1;
    r.wholeMembers = true;
    // The values, and what the reader holds besides while reading: the file's bytes or VTK's
    // array in the file's type (up to 8 bytes a value) and the compressed data.
    r.scratchFixed = r.grid.pointCount() * (sizeof(float) + 2 * sizeof(double));
    const std::size_t plane =
        static_cast<std::size_t>(r.grid.dims[0]) * static_cast<std::size_t>(r.grid.dims[1]);
    const Grid3 grid = r.grid;
    r.read = [path, o, plane, grid, opened](int z0, int z1, std::span<float> out) mutable {
        ScalarField f = opened && !opened->values.empty() ? std::move(*opened)
                                                          : detail::readFieldImpl(path, o, nullptr);
        opened.reset();
        if (f.grid.dims != grid.dims) UDVR_FAIL(path.string() << " changed while build ran");
        UDVR_CHECK(out.size() == static_cast<std::size_t>(z1 - z0) * plane);
        std::copy_n(
            f.values.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(z0) * plane),
            out.size(), out.begin());
    };
    return r;
}

}  // namespace

SlabReader openFieldSlabs(const fs::path& given, const FieldReadOptions& options) {
    const fs::path path = singleFileOf(given);
    detail::requireFile(path);
    const std::string ext = detail::lowerExtension(path);
    if (ext == ".nc" || ext == ".nc4" || ext == ".cdf")
        return detail::openFieldNetcdfSlabs(path, options.var, options.allowMissing);
    if (ext == ".nrrd" || ext == ".nhdr" || ext == ".vti") return openWholeSlabs(path, options);
    if (ext == ".raw" || options.raw.given()) return openRawSlabs(path, options.raw);
    UDVR_FAIL("cannot read " << path.string() << ": unknown field format '" << ext
                             << "' (expected .raw .nrrd .nhdr .vti .nc)");
}

}  // namespace udvr
