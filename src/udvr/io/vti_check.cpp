// The checks of CheckedVtiReader (vti_check.h): everything in a .vti that VTK 9.1's XML reader
// uses without checking, checked on the parsed elements and on the header of each array's data
// block, before VTK allocates or decodes anything.
#include "udvr/io/vti_check.h"

#include <vtkBase64InputStream.h>
#include <vtkInputStream.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkXMLDataElement.h>
#include <vtkXMLDataParser.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

namespace udvr::detail {

vtkStandardNewMacro(CheckedVtiReader);

namespace {

/// A problem found in the file: the message of CheckedVtiReader::problem().
struct Problem {
    std::string message;
};

[[noreturn]] void fail(const std::string& message) { throw Problem{message}; }

/// Bytes per value of a VTK XML type name; 0 for String (variable length). Unknown names fail
/// (VTK 9.1 dereferences the null array it makes for them).
std::size_t wordSize(const char* type, const std::string& what) {
    static const std::pair<const char*, std::size_t> kTypes[] = {
        {"Int8", 1},  {"UInt8", 1},  {"Int16", 2},   {"UInt16", 2},  {"Int32", 4},  {"UInt32", 4},
        {"Int64", 8}, {"UInt64", 8}, {"Float32", 4}, {"Float64", 8}, {"String", 0},
    };
    if (type == nullptr) fail(what + " has no type");
    for (const auto& [name, size] : kTypes)
        if (std::strcmp(type, name) == 0) return size;
    fail(what + " has type '" + type +
         "' (expected Int8, UInt8, Int16, UInt16, Int32, UInt32, Int64, UInt64, Float32, "
         "Float64 or String)");
}

/// A whole number attribute in [lo, hi]; `fallback` when absent.
long long integerAttribute(vtkXMLDataElement* e, const char* name, long long lo, long long hi,
                           long long fallback, const std::string& what) {
    const char* text = e->GetAttribute(name);
    if (text == nullptr) return fallback;
    long long v = 0;
    const char* end = text + std::strlen(text);
    while (text < end && *text == ' ') ++text;
    const auto [ptr, ec] = std::from_chars(text, end, v);
    if (ec != std::errc() || text == ptr || v < lo || v > hi)
        fail(what + ": " + name + " '" + e->GetAttribute(name) + "' is not a whole number from " +
             std::to_string(lo) + " to " + std::to_string(hi));
    return v;
}

/// An extent attribute: 6 whole numbers (x0 x1 y0 y1 z0 z1).
std::array<long long, 6> extentAttribute(vtkXMLDataElement* e, const char* name,
                                         const std::string& what) {
    const char* text = e->GetAttribute(name);
    if (text == nullptr) fail(what + " has no " + name);
    std::istringstream in(text);
    std::array<long long, 6> x{};
    for (long long& v : x)
        if (!(in >> v) || v < -(1LL << 31) || v >= (1LL << 31))
            fail(what + ": " + name + " '" + text + "' is not 6 whole numbers");
    return x;
}

/// Points and cells of an extent (VTK's structured counts: an axis of one point adds no cell
/// dimension), as long double so that no product overflows.
long double extentPoints(const std::array<long long, 6>& x) {
    long double n = 1;
    for (int a = 0; a < 3; ++a)
        n *= static_cast<long double>(std::max(0LL, x[2 * a + 1] - x[2 * a] + 1));
    return n;
}
long double extentCells(const std::array<long long, 6>& x) {
    long double n = 1;
    for (int a = 0; a < 3; ++a) {
        const long long d = x[2 * a + 1] - x[2 * a] + 1;
        if (d < 1) return 0;
        if (d > 1) n *= static_cast<long double>(d - 1);
    }
    return n;
}

/// What the root element says about every data block.
struct Layout {
    std::uintmax_t fileSize = 0;
    std::size_t headerSize = 4;   // header_type UInt32 or UInt64
    bool bigEndian = false;       // byte_order
    std::string compressor;       // "" = none
    double maxRatio = 1.0;        // the compressor's largest expansion
    bool appendedBase64 = false;  // <AppendedData encoding="base64">
    long long appendedAt = -1;    // the file offset of appended data ('_' + 1); -1: none
};

/// A String array, whose decoded bytes are checked once VTK has set up its parser.
struct StringArray {
    vtkXMLDataElement* element;
    std::string what;
    long double strings;  // how many the array holds (tuples × components)
    long long offset;     // in the appended data; < 0: inline
    bool ascii;
    long double bytes;  // decoded (ascii: at most)
};

class Checker {
  public:
    std::vector<StringArray> strings;  // found by run()

    Checker(const std::string& path, vtkXMLDataParser* parser) : path_(path), parser_(parser) {}

    void run(vtkXMLDataElement* root) {
        std::error_code ec;
        layout_.fileSize = std::filesystem::file_size(path_, ec);
        if (ec) fail("cannot read its size");
        rootAttributes(root);
        vtkXMLDataElement* image = nested(root, "ImageData");
        if (image == nullptr) fail("no ImageData element");
        if (vtkXMLDataElement* appended = nested(root, "AppendedData")) {
            const char* encoding = appended->GetAttribute("encoding");
            if (encoding == nullptr ||
                (std::strcmp(encoding, "raw") != 0 && std::strcmp(encoding, "base64") != 0))
                fail("AppendedData encoding is '" + std::string(encoding ? encoding : "") +
                     "' (expected raw or base64)");
            layout_.appendedBase64 = std::strcmp(encoding, "base64") == 0;
            layout_.appendedAt = parser_ != nullptr ? parser_->GetAppendedDataPosition() : -1;
        }
        const auto whole = extentAttribute(image, "WholeExtent", "ImageData");
        geometry(image, whole);
        wholePoints_ = extentPoints(whole);
        wholeCells_ = extentCells(whole);
        // The pieces first: points of the whole extent that no piece holds would be undefined
        // (and VTK 9.1 leaks on that path).
        long double piecePoints = 0;
        for (int i = 0; i < image->GetNumberOfNestedElements(); ++i) {
            vtkXMLDataElement* e = image->GetNestedElement(i);
            if (e->GetName() == nullptr || std::strcmp(e->GetName(), "Piece") != 0) continue;
            const auto extent = extentAttribute(e, "Extent", "Piece");
            for (int a = 0; a < 3; ++a)
                if (extent[2 * a] < whole[2 * a] || extent[2 * a + 1] > whole[2 * a + 1])
                    fail("a Piece Extent lies outside the WholeExtent");
            piecePoints += extentPoints(extent);
        }
        if (piecePoints != wholePoints_)
            fail("the Piece extents hold " + number(piecePoints) + " points, the WholeExtent " +
                 number(wholePoints_));
        for (int i = 0; i < image->GetNumberOfNestedElements(); ++i) {
            vtkXMLDataElement* e = image->GetNestedElement(i);
            const std::string name = e->GetName() ? e->GetName() : "";
            if (name == "FieldData") {
                arrays(e, -1, "FieldData");
            } else if (name == "Piece") {
                const auto extent = extentAttribute(e, "Extent", "Piece");
                for (int k = 0; k < e->GetNumberOfNestedElements(); ++k) {
                    vtkXMLDataElement* d = e->GetNestedElement(k);
                    const std::string dn = d->GetName() ? d->GetName() : "";
                    if (dn == "PointData") arrays(d, extentPoints(extent), "PointData");
                    if (dn == "CellData") arrays(d, extentCells(extent), "CellData");
                }
            }
        }
    }

  private:
    /// Origin and Spacing: 3 finite numbers each, the spacing positive, and the grid's corners
    /// finite. VTK reads a value it cannot parse ("nan", "abc") as its default (0 0 0, 1 1 1)
    /// without a word, so the text is checked here.
    static void geometry(vtkXMLDataElement* image, const std::array<long long, 6>& whole) {
        std::array<double, 3> origin{0, 0, 0}, spacing{1, 1, 1};
        for (const bool isSpacing : {false, true}) {
            const char* name = isSpacing ? "Spacing" : "Origin";
            const char* text = image->GetAttribute(name);
            if (text == nullptr) continue;
            std::array<double, 3>& v = isSpacing ? spacing : origin;
            const char* at = text;
            bool ok = true;
            for (double& x : v) {
                char* end = nullptr;
                x = std::strtod(at, &end);
                ok = ok && end != at && std::isfinite(x) && (!isSpacing || x > 0.0);
                at = end;
            }
            while (ok && *at != '\0') ok = std::isspace(static_cast<unsigned char>(*at++)) != 0;
            if (!ok)
                fail(std::string("ImageData ") + name + " '" + text + "' is not 3 finite" +
                     (isSpacing ? " positive" : "") + " numbers");
        }
        for (int a = 0; a < 3; ++a)
            for (const long long i : {whole[2 * a], whole[2 * a + 1]})
                if (!std::isfinite(origin[a] + static_cast<double>(i) * spacing[a]))
                    fail("ImageData Origin and Spacing put the grid's corner at index " +
                         std::to_string(i) + " of axis " + std::to_string(a) +
                         " beyond the largest number");
    }

    static vtkXMLDataElement* nested(vtkXMLDataElement* e, const char* name) {
        for (int i = 0; i < e->GetNumberOfNestedElements(); ++i) {
            vtkXMLDataElement* n = e->GetNestedElement(i);
            if (n->GetName() != nullptr && std::strcmp(n->GetName(), name) == 0) return n;
        }
        return nullptr;
    }

    void rootAttributes(vtkXMLDataElement* root) {
        const char* order = root->GetAttribute("byte_order");
        if (order == nullptr ||
            (std::strcmp(order, "LittleEndian") != 0 && std::strcmp(order, "BigEndian") != 0))
            fail("byte_order is '" + std::string(order ? order : "") +
                 "' (expected LittleEndian or BigEndian)");
        layout_.bigEndian = std::strcmp(order, "BigEndian") == 0;
        if (const char* header = root->GetAttribute("header_type")) {
            if (std::strcmp(header, "UInt64") == 0)
                layout_.headerSize = 8;
            else if (std::strcmp(header, "UInt32") != 0)
                fail("header_type is '" + std::string(header) + "' (expected UInt32 or UInt64)");
        }
        if (const char* c = root->GetAttribute("compressor")) {
            // The largest expansion of each codec: deflate ~1032:1, LZ4 ~255:1; LZMA has no
            // such bound and gets a generous one.
            static const std::pair<const char*, double> kCompressors[] = {
                {"vtkZLibDataCompressor", 1032.0},
                {"vtkLZ4DataCompressor", 255.0},
                {"vtkLZMADataCompressor", 65536.0},
            };
            for (const auto& [name, ratio] : kCompressors)
                if (std::strcmp(c, name) == 0) {
                    layout_.compressor = name;
                    layout_.maxRatio = ratio;
                }
            if (layout_.compressor.empty())
                fail("compressor is '" + std::string(c) +
                     "' (expected vtkZLibDataCompressor, vtkLZ4DataCompressor or "
                     "vtkLZMADataCompressor)");
        }
    }

    /// The arrays of a PointData, CellData (`tuples` each) or FieldData (tuples < 0: each
    /// array's NumberOfTuples) element.
    void arrays(vtkXMLDataElement* group, long double tuples, const char* groupName) {
        for (int i = 0; i < group->GetNumberOfNestedElements(); ++i) {
            // VTK reads every element in the group as an array, whatever its tag.
            vtkXMLDataElement* a = group->GetNestedElement(i);
            const char* arrayName = a->GetAttribute("Name");
            const std::string what =
                std::string(groupName) + " array '" + (arrayName ? arrayName : "") + "'";
            const std::size_t word = wordSize(a->GetAttribute("type"), what);
            const long long components =
                integerAttribute(a, "NumberOfComponents", 1, 1 << 20, 1, what);
            long double n = tuples;  // values of the array
            if (tuples < 0) {
                // Field data: VTK reads an array without NumberOfTuples as empty and crashes
                // on the data it then finds (a null block in vtkXMLDataParser::ReadBlock).
                const long long t = integerAttribute(a, "NumberOfTuples", 0, 1LL << 53, -1, what);
                if (t < 0) fail(what + " has no NumberOfTuples");
                n = static_cast<long double>(t);
            }
            n *= static_cast<long double>(components);
            // The output array VTK allocates for the whole extent, before reading the data.
            const long double whole =
                tuples < 0
                    ? n
                    : (std::strcmp(groupName, "PointData") == 0 ? wholePoints_ : wholeCells_) *
                          static_cast<long double>(components);
            const long double bound =
                layout_.maxRatio * static_cast<long double>(layout_.fileSize) + (1 << 20);
            if (whole * static_cast<long double>(std::max<std::size_t>(word, 1)) > bound)
                fail(what + " would hold " + number(whole) + " values, more than a file of " +
                     std::to_string(layout_.fileSize) + " bytes can");
            // As VTK decides (vtkXMLReader::ReadArrayValues): an `offset` means appended data
            // whatever the format says; else "binary" is inline base64 and anything else ascii.
            const char* format = a->GetAttribute("format");
            const std::string f = format ? format : "";
            StringArray text{a, what, n, -1, false, 0};
            if (a->GetAttribute("offset") != nullptr) {
                if (layout_.appendedAt < 0)
                    fail(what + " has an offset but there is no AppendedData");
                text.offset = integerAttribute(a, "offset", 0, 1LL << 62, -1, what);
                text.bytes =
                    block(layout_.appendedAt + text.offset, layout_.appendedBase64, n, word, what);
            } else if (f == "binary") {
                text.bytes = block(inlineDataPosition(a), true, n, word, what);
            } else if (f == "ascii") {
                if (n > static_cast<long double>(layout_.fileSize))
                    fail(what + " would hold " + number(n) + " ascii values in " +
                         std::to_string(layout_.fileSize) + " bytes");
                text.ascii = true;
                text.bytes = static_cast<long double>(layout_.fileSize);  // at most
            } else {
                fail(what + " has format '" + f +
                     "' (expected ascii, binary, or appended with an offset)");
            }
            if (word == 0) strings.push_back(text);
        }
    }

    /// Where VTK's parser finds inline data: after the first '>' from the element's start, and
    /// whitespace (vtkXMLDataParser::SeekInlineDataPosition).
    long long inlineDataPosition(vtkXMLDataElement* e) {
        std::ifstream in(path_, std::ios::binary);
        in.seekg(static_cast<std::streamoff>(e->GetXMLByteIndex()));
        char c = 0;
        while (in.get(c) && c != '>') {
        }
        while (in.get(c) && std::isspace(static_cast<unsigned char>(c))) {
        }
        if (!in) return static_cast<long long>(layout_.fileSize);
        return static_cast<long long>(in.tellg()) - 1;
    }

    /// The header of one data block at `at`: compressed, the block count, block size, last
    /// block size and each block's compressed size; else the byte count. `n` values of `word`
    /// bytes are expected (n < 0 or word 0: not known).
    long double block(long long at, bool base64, long double n, std::size_t word,
                      const std::string& what) {
        if (at < 0 || static_cast<std::uintmax_t>(at) >= layout_.fileSize)
            fail(what + ": its data would start at byte " + std::to_string(at) + " of " +
                 std::to_string(layout_.fileSize));
        std::ifstream file(path_, std::ios::binary);
        file.seekg(static_cast<std::streamoff>(at));
        vtkNew<vtkInputStream> rawStream;
        vtkNew<vtkBase64InputStream> base64Stream;
        vtkInputStream* stream = base64 ? base64Stream.Get() : rawStream.Get();
        stream->SetStream(&file);
        stream->StartReading();
        const std::size_t h = layout_.headerSize;
        // Encoded bytes a decoded length takes, and what is left of the file after `at`.
        const auto encoded = [&](long double bytes) { return base64 ? bytes * 4 / 3 : bytes; };
        const long double left =
            static_cast<long double>(layout_.fileSize - static_cast<std::uintmax_t>(at));
        const auto word64 = [&](const std::string& name) -> std::uint64_t {
            unsigned char b[8] = {};
            if (stream->Read(b, h) != h) {
                if (!base64)
                    fail(truncated(what, static_cast<long double>(at + static_cast<long long>(h))));
                fail(what + ": its data block header (" + name + ") is cut short");
            }
            std::uint64_t v = 0;
            for (std::size_t i = 0; i < h; ++i)
                v = layout_.bigEndian ? (v << 8) | b[i] : v | (std::uint64_t{b[i]} << (8 * i));
            return v;
        };
        const long double expected = n >= 0 && word > 0 ? n * static_cast<long double>(word) : -1;
        long double bytes = 0, stored = 0;  // decoded bytes, and bytes in the file
        if (layout_.compressor.empty()) {
            bytes = static_cast<long double>(word64("byte count"));
            stored = static_cast<long double>(h) + bytes;
        } else {
            const std::uint64_t blocks = word64("block count");
            const std::uint64_t size = word64("block size");
            const std::uint64_t last = word64("last block size");
            if (static_cast<long double>(blocks) * static_cast<long double>(h) > left)
                fail(what + ": its compression header lists " + std::to_string(blocks) +
                     " blocks, more than the file holds");
            // VTK divides by the block size and allocates one block even for no blocks.
            if (size == 0) fail(what + ": its compression header has block size 0");
            if (static_cast<long double>(size) >
                layout_.maxRatio * static_cast<long double>(layout_.fileSize) + (1 << 20))
                fail(what + ": its compression header has block size " + std::to_string(size) +
                     ", more than a file of " + std::to_string(layout_.fileSize) +
                     " bytes can hold");
            if (last > size)
                fail(what + ": its compression header's last block (" + std::to_string(last) +
                     " bytes) is larger than a block (" + std::to_string(size) + ")");
            bytes = blocks == 0
                        ? 0
                        : static_cast<long double>(blocks - 1) * static_cast<long double>(size) +
                              static_cast<long double>(last > 0 ? last : size);
            long double compressed = 0;
            for (std::uint64_t b = 0; b < blocks; ++b)
                compressed += static_cast<long double>(word64("block sizes"));
            stored = static_cast<long double>((3 + blocks) * h) + compressed;
            if (bytes > layout_.maxRatio * compressed + 64 * static_cast<long double>(blocks))
                fail(what + ": its compression header promises " + number(bytes) + " bytes from " +
                     number(compressed) + " compressed ones");
        }
        stream->EndReading();
        if (encoded(stored) > left + 8)
            fail(truncated(what, static_cast<long double>(at) + encoded(stored)));
        if (expected >= 0 && bytes != expected)
            fail(what + ": its data block holds " + number(bytes) + " bytes, the array needs " +
                 number(expected));
        if (expected < 0 &&
            bytes > layout_.maxRatio * static_cast<long double>(layout_.fileSize) + (1 << 20))
            fail(what + ": its data block claims " + number(bytes) + " bytes");
        return bytes;
    }

    std::string truncated(const std::string& what, long double needed) const {
        return "truncated data (" + what + "): expected at least " + number(needed) +
               " bytes, found " + std::to_string(layout_.fileSize);
    }

    /// A count for a message: whole numbers in full up to 2^63, else in floating point.
    static std::string number(long double v) {
        if (v >= 0 && v < 9.2e18L && v == static_cast<long double>(static_cast<long long>(v)))
            return std::to_string(static_cast<long long>(v));
        std::ostringstream os;
        os << static_cast<double>(v);
        return os.str();
    }

    std::string path_;
    vtkXMLDataParser* parser_;
    Layout layout_;
    long double wholePoints_ = 0, wholeCells_ = 0;
};

/// VTK 9.1 stores every NUL-terminated string of a String array's data, past the end of the
/// array when there are more than its tuples (a heap overflow found by fuzzing): the data, read
/// through VTK's parser once it is set up (decompression included), must hold exactly as many.
void checkStrings(vtkXMLDataParser* parser, const std::vector<StringArray>& arrays) {
    for (const StringArray& a : arrays) {
        std::vector<unsigned char> data(static_cast<std::size_t>(a.bytes));
        const std::size_t read =
            data.empty() ? 0
            : a.offset >= 0
                ? parser->ReadAppendedData(a.offset, data.data(), 0, data.size(), VTK_UNSIGNED_CHAR)
                : parser->ReadInlineData(a.element, a.ascii ? 1 : 0, data.data(), 0, data.size(),
                                         VTK_UNSIGNED_CHAR);
        if (!a.ascii && read != data.size())
            fail(a.what + ": cannot decode its data (" + std::to_string(read) + " of " +
                 std::to_string(data.size()) + " bytes)");
        data.resize(std::min(read, data.size()));
        const auto terminated =
            static_cast<long double>(std::count(data.begin(), data.end(), '\0'));
        if (terminated != a.strings || (!data.empty() && data.back() != '\0'))
            fail(a.what + ": its data holds " + std::to_string(static_cast<long long>(terminated)) +
                 " NUL-terminated strings, the array " +
                 std::to_string(static_cast<long long>(a.strings)));
    }
}

}  // namespace

int CheckedVtiReader::ReadVTKFile(vtkXMLDataElement* root) {
    problem_.clear();
    try {
        Checker checker(GetFileName() ? GetFileName() : "", GetXMLParser());
        checker.run(root);
        // VTK sets up the parser (byte order, header type, compressor) here, before it reads
        // any data.
        if (Superclass::ReadVTKFile(root) == 0) return 0;
        checkStrings(GetXMLParser(), checker.strings);
    } catch (const Problem& p) {
        problem_ = p.message;
        return 0;
    }
    return 1;
}

}  // namespace udvr::detail

namespace udvr::detail {

std::string xmlNestingProblem(const std::filesystem::path& path, int maxDepth) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return "";  // the reader says why it cannot open it
    std::vector<char> buffer(1 << 16);
    std::size_t size = 0, at = 0;  // bytes in the buffer, the next one to look at
    std::uint64_t offset = 0;      // file offset of buffer[0]
    const auto next = [&](char& c) {
        if (at == size) {
            offset += size;
            in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
            size = static_cast<std::size_t>(in.gcount());
            at = 0;
            if (size == 0) return false;
        }
        c = buffer[at++];
        return true;
    };
    // Skip to just after `end` (a comment's "-->", a PI's "?>", CDATA's "]]>").
    const auto skipPast = [&](const char* end) {
        const std::size_t n = std::strlen(end);
        std::size_t matched = 0;
        char c;
        while (next(c)) {
            matched = c == end[matched] ? matched + 1 : (c == end[0] ? 1 : 0);
            if (matched == n) return;
        }
    };
    int depth = 0;
    char c;
    while (next(c)) {
        if (c != '<') continue;
        const std::uint64_t tagAt = offset + at - 1;
        if (!next(c)) break;
        if (c == '?') {
            skipPast("?>");
            continue;
        }
        if (c == '!') {
            char d = 0;
            if (!next(d)) break;
            if (d == '-') {
                skipPast("-->");
            } else if (d == '[') {
                skipPast("]]>");
            } else {  // <!DOCTYPE …>, with an internal subset in brackets
                int brackets = 0;
                while (next(d) && !(d == '>' && brackets == 0))
                    brackets += d == '[' ? 1 : d == ']' ? -1 : 0;
            }
            continue;
        }
        const bool closing = c == '/';
        std::string name;
        char quote = 0, last = c;
        if (!closing) name += c;
        bool nameDone = false;
        while (next(c)) {
            if (quote != 0) {
                if (c == quote) quote = 0;
            } else if (c == '"' || c == '\'') {
                quote = c;
            } else if (c == '>') {
                break;
            }
            if (!nameDone && quote == 0 &&
                (c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '/' || c == '>'))
                nameDone = true;
            if (!nameDone && name.size() < 64) name += c;
            if (c != ' ' && c != '\t' && c != '\n' && c != '\r') last = c;
        }
        if (closing) {
            --depth;
            continue;
        }
        if (last == '/') continue;  // <empty/>
        if (++depth > maxDepth)
            return "XML elements nested deeper than " + std::to_string(maxDepth) + " (at byte " +
                   std::to_string(tagAt) + ")";
        if (name == "AppendedData") break;  // raw bytes follow, up to its end tag
    }
    return "";
}

}  // namespace udvr::detail
