// NumPy .npy headers: a small recursive-descent parser for the Python literal NumPy writes.
#include "udvr/io/npy.h"

#include <cctype>
#include <cstdint>
#include <limits>
#include <map>
#include <sstream>

#include "udvr/util/check.h"

namespace udvr {
namespace {

constexpr std::string_view kMagic{"\x93NUMPY", 6};

/// A Python literal as far as a .npy header needs: str, bool, None, int, tuple or list.
struct PyValue {
    enum class Kind { Str, Bool, None, Int, Seq };
    Kind kind = Kind::None;
    std::string str;
    bool boolean = false;
    long long integer = 0;
    std::vector<PyValue> items;  // tuple or list elements
};

/// Parses the header dict; every error names the source and what was found.
class DictParser {
  public:
    DictParser(std::string_view text, const std::string& what) : text_(text), what_(what) {}

    std::map<std::string, PyValue> parseDict() {
        std::map<std::string, PyValue> out;
        expect('{');
        skipSpace();
        while (peek() != '}') {
            if (peek() != '\'' && peek() != '"') fail("expected a quoted key");
            std::string key = parseString();
            expect(':');
            if (out.count(key)) fail("key '" + key + "' appears twice");
            out[key] = parseValue();
            skipSpace();
            if (peek() == ',') {
                ++pos_;
                skipSpace();
            } else if (peek() != '}') {
                fail("expected ',' or '}'");
            }
        }
        ++pos_;
        skipSpace();
        if (pos_ != text_.size()) fail("text after the closing '}'");
        return out;
    }

  private:
    [[noreturn]] void fail(const std::string& message) const {
        UDVR_FAIL(what_ << ": malformed NPY header: " << message << " at character " << pos_
                        << " of the header dict");
    }
    void skipSpace() {
        while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
    }
    char peek() const { return pos_ < text_.size() ? text_[pos_] : '\0'; }
    void expect(char c) {
        skipSpace();
        if (peek() != c) fail(std::string("expected '") + c + "'");
        ++pos_;
    }

    std::string parseString() {
        const char quote = text_[pos_++];
        std::string s;
        while (pos_ < text_.size() && text_[pos_] != quote) {
            if (text_[pos_] == '\\' && pos_ + 1 < text_.size()) ++pos_;
            s += text_[pos_++];
        }
        if (pos_ >= text_.size()) fail("unterminated string");
        ++pos_;
        return s;
    }

    PyValue parseValue() {
        skipSpace();
        PyValue v;
        const char c = peek();
        if (c == '\'' || c == '"') {
            v.kind = PyValue::Kind::Str;
            v.str = parseString();
        } else if (c == '(' || c == '[') {
            v.kind = PyValue::Kind::Seq;
            const char close = c == '(' ? ')' : ']';
            ++pos_;
            skipSpace();
            while (peek() != close) {
                v.items.push_back(parseValue());
                skipSpace();
                if (peek() == ',') {
                    ++pos_;
                    skipSpace();
                } else if (peek() != close) {
                    fail(std::string("expected ',' or '") + close + "'");
                }
            }
            ++pos_;
        } else if (c == '-' || std::isdigit(static_cast<unsigned char>(c))) {
            v.kind = PyValue::Kind::Int;
            const bool negative = c == '-';
            if (negative) ++pos_;
            if (!std::isdigit(static_cast<unsigned char>(peek()))) fail("expected a digit");
            unsigned long long magnitude = 0;
            while (std::isdigit(static_cast<unsigned char>(peek()))) {
                magnitude = magnitude * 10 + static_cast<unsigned>(text_[pos_++] - '0');
                if (magnitude >
                    static_cast<unsigned long long>(std::numeric_limits<long long>::max()))
                    fail("integer too large");
            }
            if (peek() == 'L' || peek() == 'l') ++pos_;  // Python 2 long suffix
            v.integer =
                negative ? -static_cast<long long>(magnitude) : static_cast<long long>(magnitude);
        } else {
            std::size_t end = pos_;
            while (end < text_.size() && std::isalpha(static_cast<unsigned char>(text_[end])))
                ++end;
            const std::string_view word = text_.substr(pos_, end - pos_);
            if (word == "True" || word == "False") {
                v.kind = PyValue::Kind::Bool;
                v.boolean = word == "True";
            } else if (word == "None") {
                v.kind = PyValue::Kind::None;
            } else {
                fail("unexpected '" + std::string(1, c) + "'");
            }
            pos_ = end;
        }
        return v;
    }

    std::string_view text_;
    const std::string& what_;
    std::size_t pos_ = 0;
};

std::uint32_t loadLittle(std::string_view bytes, std::size_t at, int count) {
    std::uint32_t v = 0;
    for (int b = count - 1; b >= 0; --b)
        v = (v << 8) | static_cast<unsigned char>(bytes[at + static_cast<std::size_t>(b)]);
    return v;
}

}  // namespace

std::size_t NpyHeader::elementCount() const {
    std::size_t n = 1;
    for (long long d : shape) n *= static_cast<std::size_t>(d);
    return n;
}

NpyHeader parseNpyHeader(std::string_view bytes, const std::string& what) {
    if (bytes.size() < kMagic.size() || bytes.substr(0, kMagic.size()) != kMagic)
        UDVR_FAIL(what << ": not a NPY file (bad magic; expected \\x93NUMPY)");
    if (bytes.size() < 10) UDVR_FAIL(what << ": truncated NPY header");
    NpyHeader h;
    h.majorVersion = static_cast<unsigned char>(bytes[6]);
    std::size_t lengthBytes = 0;
    if (h.majorVersion == 1)
        lengthBytes = 2;
    else if (h.majorVersion == 2 || h.majorVersion == 3)
        lengthBytes = 4;
    else
        UDVR_FAIL(what << ": unsupported NPY version " << h.majorVersion << "."
                       << static_cast<int>(static_cast<unsigned char>(bytes[7]))
                       << " (expected 1.0, 2.0 or 3.0)");
    if (bytes.size() < 8 + lengthBytes) UDVR_FAIL(what << ": truncated NPY header");
    const std::size_t dictLength = loadLittle(bytes, 8, static_cast<int>(lengthBytes));
    const std::size_t dictStart = 8 + lengthBytes;
    if (bytes.size() < dictStart + dictLength)
        UDVR_FAIL(what << ": truncated NPY header: expected " << dictStart + dictLength
                       << " bytes, found " << bytes.size());
    h.dataOffset = dictStart + dictLength;

    const std::map<std::string, PyValue> dict =
        DictParser(bytes.substr(dictStart, dictLength), what).parseDict();
    const auto get = [&](const char* key) -> const PyValue& {
        const auto it = dict.find(key);
        if (it == dict.end()) UDVR_FAIL(what << ": NPY header has no '" << key << "'");
        return it->second;
    };
    const PyValue& descr = get("descr");
    if (descr.kind != PyValue::Kind::Str)
        UDVR_FAIL(what << ": NPY 'descr' is a structured dtype; expected a simple one such as "
                          "'<f4'");
    h.descr = descr.str;
    const PyValue& fortran = get("fortran_order");
    if (fortran.kind != PyValue::Kind::Bool)
        UDVR_FAIL(what << ": NPY 'fortran_order' must be True or False");
    h.fortranOrder = fortran.boolean;
    const PyValue& shape = get("shape");
    if (shape.kind != PyValue::Kind::Seq)
        UDVR_FAIL(what << ": NPY 'shape' must be a tuple of integers");
    for (const PyValue& d : shape.items) {
        if (d.kind != PyValue::Kind::Int || d.integer < 0)
            UDVR_FAIL(what << ": NPY 'shape' must hold non-negative integers");
        h.shape.push_back(d.integer);
    }
    // Products that overflow size_t cannot describe a file that exists.
    std::size_t n = 1;
    for (long long d : h.shape) {
        const auto ud = static_cast<std::size_t>(d);
        if (ud != 0 && n > std::numeric_limits<std::size_t>::max() / 16 / ud)
            UDVR_FAIL(what << ": NPY 'shape' is too large");
        n *= ud;
    }
    return h;
}

std::string npyHeaderBytes(const std::string& descr, const std::vector<long long>& shape) {
    std::ostringstream dict;
    dict << "{'descr': '" << descr << "', 'fortran_order': False, 'shape': (";
    for (std::size_t i = 0; i < shape.size(); ++i) dict << (i ? ", " : "") << shape[i];
    dict << (shape.size() == 1 ? ",), }" : "), }");
    std::string text = dict.str();
    const bool v2 = text.size() + 12 + 64 > 65535;
    const std::size_t prefix = v2 ? 12 : 10;
    // Pad with spaces so that the data starts on a 64-byte boundary; the dict ends with '\n'.
    text.append((64 - (prefix + text.size() + 1) % 64) % 64, ' ');
    text.push_back('\n');
    std::string out(kMagic);
    out.push_back(static_cast<char>(v2 ? 2 : 1));
    out.push_back('\0');
    const std::size_t length = text.size();
    for (std::size_t b = 0; b < (v2 ? 4u : 2u); ++b)
        out.push_back(static_cast<char>((length >> (8 * b)) & 0xFF));
    out += text;
    return out;
}

}  // namespace udvr
