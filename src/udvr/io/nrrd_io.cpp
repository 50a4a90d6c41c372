// NRRD files (.nrrd, .nhdr; NRRD0001 … NRRD0005): the header, attached or detached data, raw,
// gzip or ascii encodings, the grid from spacings or space directions.
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <climits>
#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "udvr/io/io_detail.h"
#include "udvr/io/scalar_type.h"
#include "udvr/util/check.h"

namespace udvr::detail {
namespace fs = std::filesystem;
namespace {

std::string trim(const std::string& s) {
    std::size_t b = s.find_first_not_of(" \t\r\n");
    if (b == std::string::npos) return "";
    std::size_t e = s.find_last_not_of(" \t\r\n");
    return s.substr(b, e - b + 1);
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

}  // namespace

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
    std::size_t expected = checkedDataBytes(path, f.grid.dims, typeSize(*h.type));
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

}  // namespace udvr::detail
