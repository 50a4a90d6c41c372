// Image files (SPEC §5): PNG through libpng, float images as NPY and PFM.
#include "udvr/io/image.h"

#include <png.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <csetjmp>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>
#include <sstream>
#include <string>

#include "udvr/io/io_detail.h"
#include "udvr/io/npy.h"
#include "udvr/util/atomic_file.h"
#include "udvr/util/check.h"

namespace udvr {
namespace fs = std::filesystem;

namespace {

// ---- libpng, C style: between setjmp and a longjmp only trivially destructible locals live ----

struct PngErrorState {
    char message[256] = "unknown libpng error";
};

void pngError(png_structp png, png_const_charp message) {
    auto* state = static_cast<PngErrorState*>(png_get_error_ptr(png));
    std::snprintf(state->message, sizeof(state->message), "%s", message);
    png_longjmp(png, 1);
}

void pngWarning(png_structp, png_const_charp) {}  // benign chunks (e.g. iCCP) are not errors

void pngAppend(png_structp png, png_bytep data, png_size_t length) {
    auto* out = static_cast<std::vector<unsigned char>*>(png_get_io_ptr(png));
    out->insert(out->end(), data, data + length);
}
void pngFlushNothing(png_structp) {}

/// To `fp`, or with fp null to `*memory`; zlib `level` (-1: libpng's default). Returns false
/// (with err->message) on a libpng error.
bool pngWriteRgba8(FILE* fp, std::vector<unsigned char>* memory, int level,
                   const unsigned char* rgba, int width, int height, PngErrorState* err,
                   const PngText* text = nullptr) {
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, err, pngError, pngWarning);
    if (png == nullptr) return false;
    png_infop info = png_create_info_struct(png);
    if (info == nullptr || setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        return false;
    }
    if (fp)
        png_init_io(png, fp);
    else
        png_set_write_fn(png, memory, pngAppend, pngFlushNothing);
    if (level >= 0) png_set_compression_level(png, level);
    png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), 8,
                 PNG_COLOR_TYPE_RGBA, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    std::vector<png_text> chunks;
    if (text != nullptr)
        for (const auto& [key, value] : *text) {
            png_text t{};
            t.compression = PNG_TEXT_COMPRESSION_NONE;
            t.key = const_cast<char*>(key.c_str());
            t.text = const_cast<char*>(value.c_str());
            t.text_length = value.size();
            chunks.push_back(t);
        }
    if (!chunks.empty()) png_set_text(png, info, chunks.data(), static_cast<int>(chunks.size()));
    png_write_info(png, info);
    for (int y = 0; y < height; ++y) {
        png_write_row(png,
                      rgba + static_cast<std::size_t>(y) * static_cast<std::size_t>(width) * 4);
    }
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
    return true;
}

struct PngPixels {
    int width = 0, height = 0;
    int bytesPerChannel = 1;        // 1 or 2 (big-endian 16-bit samples)
    unsigned char* data = nullptr;  // malloc'ed, RGBA rows
};

/// Decode any PNG to RGBA (8 or 16 bits). Returns false (with err->message) on a libpng error.
bool pngReadRgba(FILE* fp, PngPixels* out, PngErrorState* err) {
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, err, pngError, pngWarning);
    if (png == nullptr) return false;
    png_infop info = png_create_info_struct(png);
    if (info == nullptr || setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, nullptr);
        std::free(out->data);
        out->data = nullptr;
        return false;
    }
    png_init_io(png, fp);
    png_read_info(png, info);
    png_uint_32 width = png_get_image_width(png, info);
    png_uint_32 height = png_get_image_height(png, info);
    int depth = png_get_bit_depth(png, info);
    int color = png_get_color_type(png, info);
    // Palette → RGB, gray < 8 bits → 8, tRNS → alpha; gray → RGB; opaque alpha where absent.
    png_set_expand(png);
    if (color == PNG_COLOR_TYPE_GRAY || color == PNG_COLOR_TYPE_GRAY_ALPHA) {
        png_set_gray_to_rgb(png);
    }
    if (!(color & PNG_COLOR_MASK_ALPHA) && !png_get_valid(png, info, PNG_INFO_tRNS)) {
        png_set_add_alpha(png, depth == 16 ? 0xffff : 0xff, PNG_FILLER_AFTER);
    }
    int passes = png_set_interlace_handling(png);
    png_read_update_info(png, info);
    std::size_t rowBytes = png_get_rowbytes(png, info);
    out->width = static_cast<int>(width);
    out->height = static_cast<int>(height);
    out->bytesPerChannel = depth == 16 ? 2 : 1;
    if (rowBytes !=
        static_cast<std::size_t>(width) * 4 * static_cast<std::size_t>(out->bytesPerChannel)) {
        png_error(png, "unexpected row size after conversion to RGBA");
    }
    out->data = static_cast<unsigned char*>(std::malloc(rowBytes * height));
    if (out->data == nullptr) png_error(png, "out of memory");
    for (int pass = 0; pass < passes; ++pass) {
        for (png_uint_32 y = 0; y < height; ++y)
            png_read_row(png, out->data + y * rowBytes, nullptr);
    }
    png_read_end(png, nullptr);
    png_destroy_read_struct(&png, &info, nullptr);
    return true;
}

struct FileCloser {
    void operator()(FILE* f) const {
        if (f) std::fclose(f);
    }
};

// ---- float images ----------------------------------------------------------------------------

std::string readBytes(const fs::path& path) {
    detail::requireFile(path);
    std::ifstream in(path, std::ios::binary);
    if (!in) UDVR_FILE_FAIL("cannot open " << path.string());
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

template <class T>
void storeLittle(std::string& out, T v) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    if constexpr (std::endian::native == std::endian::big) std::reverse(b, b + sizeof(T));
    out.append(reinterpret_cast<const char*>(b), sizeof(T));
}

void checkFiniteImage(const fs::path& path, const ImageRgba& image) {
    std::size_t bad = 0, first = 0;
    for (std::size_t i = 0; i < image.rgba.size(); ++i) {
        if (!std::isfinite(image.rgba[i]) && bad++ == 0) first = i;
    }
    if (bad > 0) {
        std::size_t p = first / 4;
        UDVR_FAIL(path.string() << ": " << bad << " NaN/Inf values, the first at pixel (x,y) = ("
                                << p % static_cast<std::size_t>(image.width) << ","
                                << p / static_cast<std::size_t>(image.width)
                                << "); expected finite values");
    }
}

std::string npyBytes(const ImageRgba& image) {
    std::ostringstream dict;
    dict << "{'descr': '<f4', 'fortran_order': False, 'shape': (" << image.height << ", "
         << image.width << ", 4), }";
    std::string header = dict.str();
    // Magic (6) + version (2) + length (2) + header, padded with spaces and '\n' to 64 bytes.
    std::size_t total = 10 + header.size() + 1;
    header.append((64 - total % 64) % 64, ' ');
    header.push_back('\n');
    std::string out("\x93NUMPY\x01\x00", 8);
    storeLittle<std::uint16_t>(out, static_cast<std::uint16_t>(header.size()));
    out += header;
    out.reserve(out.size() + image.rgba.size() * 4);
    for (float v : image.rgba) storeLittle<float>(out, v);
    return out;
}

/// Value of `key` in a NPY header dict, up to the next top-level ',' or '}'.
std::string npyField(const fs::path& path, const std::string& dict, const std::string& key) {
    std::size_t k = dict.find("'" + key + "'");
    if (k == std::string::npos) k = dict.find("\"" + key + "\"");
    if (k == std::string::npos) UDVR_FAIL(path.string() << ": NPY header has no '" << key << "'");
    std::size_t colon = dict.find(':', k);
    if (colon == std::string::npos) UDVR_FAIL(path.string() << ": malformed NPY header");
    std::size_t b = colon + 1, e = b;
    int depth = 0;
    for (; e < dict.size(); ++e) {
        char c = dict[e];
        if (c == '(') ++depth;
        if (c == ')') --depth;
        if (depth == 0 && (c == ',' || c == '}')) break;
    }
    std::string v = dict.substr(b, e - b);
    v.erase(0, v.find_first_not_of(" "));
    v.erase(v.find_last_not_of(" ") + 1);
    return v;
}

ImageRgba readNpy(const fs::path& path) {
    std::string bytes = readBytes(path);
    if (bytes.size() < 10 || bytes.compare(0, 6, "\x93NUMPY") != 0) {
        UDVR_FAIL(path.string() << ": not a NPY file (bad magic)");
    }
    int major = static_cast<unsigned char>(bytes[6]);
    std::size_t headerLen = 0, headerStart = 0;
    if (major == 1) {
        headerLen = loadLittle<std::uint16_t>(bytes.data() + 8);
        headerStart = 10;
    } else if (major == 2 || major == 3) {
        if (bytes.size() < 12) UDVR_FAIL(path.string() << ": truncated NPY header");
        headerLen = loadLittle<std::uint32_t>(bytes.data() + 8);
        headerStart = 12;
    } else {
        UDVR_FAIL(path.string() << ": unsupported NPY version " << major);
    }
    if (bytes.size() < headerStart + headerLen) {
        UDVR_FAIL(path.string() << ": truncated NPY header: expected " << headerStart + headerLen
                                << " bytes, found " << bytes.size());
    }
    std::string dict = bytes.substr(headerStart, headerLen);
    std::string descr = npyField(path, dict, "descr");
    std::string fortran = npyField(path, dict, "fortran_order");
    std::string shape = npyField(path, dict, "shape");
    descr.erase(
        std::remove_if(descr.begin(), descr.end(), [](char c) { return c == '\'' || c == '"'; }),
        descr.end());
    std::size_t itemSize = 0;
    if (descr == "<f4") {
        itemSize = 4;
    } else if (descr == "<f8") {
        itemSize = 8;
    } else {
        UDVR_FAIL(path.string() << ": NPY dtype '" << descr << "' unsupported (expected '<f4' or "
                                << "'<f8')");
    }
    if (fortran != "False") {
        UDVR_FAIL(path.string() << ": NPY fortran_order " << fortran << " unsupported (expected "
                                << "False)");
    }
    std::string inner = shape;
    std::replace(inner.begin(), inner.end(), '(', ' ');
    std::replace(inner.begin(), inner.end(), ')', ' ');
    std::replace(inner.begin(), inner.end(), ',', ' ');
    std::istringstream is(inner);
    std::vector<long long> dims;
    for (long long d; is >> d;) dims.push_back(d);
    if (dims.size() != 3 || (dims[2] != 3 && dims[2] != 4) || dims[0] < 1 || dims[1] < 1 ||
        dims[0] > INT32_MAX || dims[1] > INT32_MAX) {
        UDVR_FAIL(path.string() << ": NPY shape " << shape
                                << " unsupported (expected (height, width, 3 or 4))");
    }
    ImageRgba image;
    image.height = static_cast<int>(dims[0]);
    image.width = static_cast<int>(dims[1]);
    std::size_t channels = static_cast<std::size_t>(dims[2]);
    std::size_t pixels =
        static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height);
    std::size_t expected = pixels * channels * itemSize;
    std::size_t actual = bytes.size() - headerStart - headerLen;
    if (actual != expected) {
        UDVR_FAIL(path.string() << (actual < expected ? ": truncated NPY data"
                                                      : ": NPY shape does not match the data")
                                << ": expected " << expected << " bytes, found " << actual);
    }
    image.rgba.assign(pixels * 4, 1.0f);
    const char* data = bytes.data() + headerStart + headerLen;
    for (std::size_t p = 0; p < pixels; ++p) {
        for (std::size_t c = 0; c < channels; ++c) {
            const char* src = data + (p * channels + c) * itemSize;
            image.rgba[p * 4 + c] = itemSize == 4 ? loadLittle<float>(src)
                                                  : static_cast<float>(loadLittle<double>(src));
        }
    }
    checkFiniteImage(path, image);
    return image;
}

std::string pfmBytes(const ImageRgba& image) {
    std::string out =
        "PF\n" + std::to_string(image.width) + " " + std::to_string(image.height) + "\n-1.0\n";
    out.reserve(out.size() + image.rgba.size() * 3);
    for (int y = image.height - 1; y >= 0; --y) {  // PFM rows run bottom to top
        for (int x = 0; x < image.width; ++x) {
            const float* p = image.pixel(x, y);
            for (int c = 0; c < 3; ++c) storeLittle<float>(out, p[c]);
        }
    }
    return out;
}

ImageRgba readPfm(const fs::path& path) {
    std::string bytes = readBytes(path);
    std::size_t pos = 0;
    auto token = [&]() {
        while (pos < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[pos]))) ++pos;
        std::size_t b = pos;
        while (pos < bytes.size() && !std::isspace(static_cast<unsigned char>(bytes[pos]))) ++pos;
        return bytes.substr(b, pos - b);
    };
    std::string magic = token();
    if (magic != "PF" && magic != "Pf") {
        UDVR_FAIL(path.string() << ": not a PFM file (magic '" << magic.substr(0, 8)
                                << "', expected PF or Pf)");
    }
    std::string ws = token(), hs = token(), ss = token();
    long long w = 0, h = 0;
    double scale = 0.0;
    try {
        w = std::stoll(ws);
        h = std::stoll(hs);
        scale = std::stod(ss);
    } catch (const std::exception&) {
        UDVR_FAIL(path.string() << ": malformed PFM header (width, height, scale expected)");
    }
    if (w < 1 || h < 1 || w > INT32_MAX || h > INT32_MAX || scale == 0.0 || !std::isfinite(scale)) {
        UDVR_FAIL(path.string() << ": bad PFM header values (" << ws << " " << hs << " " << ss
                                << ")");
    }
    ++pos;  // exactly one whitespace character ends the header
    ImageRgba image;
    image.width = static_cast<int>(w);
    image.height = static_cast<int>(h);
    std::size_t channels = magic == "PF" ? 3 : 1;
    std::size_t pixels = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
    std::size_t expected = pixels * channels * 4;
    std::size_t actual = pos <= bytes.size() ? bytes.size() - pos : 0;
    if (actual != expected) {
        UDVR_FAIL(path.string() << (actual < expected ? ": truncated PFM data"
                                                      : ": PFM size does not match the data")
                                << ": expected " << expected << " bytes, found " << actual);
    }
    bool swap = (scale < 0) != (std::endian::native == std::endian::little);
    image.rgba.assign(pixels * 4, 1.0f);
    const char* data = bytes.data() + pos;
    for (int y = 0; y < image.height; ++y) {
        int fileRow = image.height - 1 - y;
        for (int x = 0; x < image.width; ++x) {
            float* dst = image.pixel(x, y);
            for (std::size_t c = 0; c < 3; ++c) {
                std::size_t idx = (static_cast<std::size_t>(fileRow) * static_cast<std::size_t>(w) +
                                   static_cast<std::size_t>(x)) *
                                      channels +
                                  (channels == 3 ? c : 0);
                unsigned char b[4];
                std::memcpy(b, data + idx * 4, 4);
                if (swap) std::reverse(b, b + 4);
                std::memcpy(&dst[c], b, 4);
            }
        }
    }
    checkFiniteImage(path, image);
    return image;
}

void checkImage(const ImageRgba& image) {
    UDVR_CHECK_MSG(image.width > 0 && image.height > 0 &&
                       image.rgba.size() == static_cast<std::size_t>(image.width) *
                                                static_cast<std::size_t>(image.height) * 4,
                   "image size");
}

}  // namespace

std::vector<unsigned char> pngBytes8(const ImageRgba& image) {
    checkImage(image);
    std::vector<unsigned char> bytes(image.rgba.size());
    for (std::size_t i = 0; i < bytes.size(); ++i) {
        float v = image.rgba[i];
        v = std::isnan(v) ? 0.0f : std::clamp(v, 0.0f, 1.0f);
        // = std::lround(v * 255.0f) for every float v in [0, 1] (checked exhaustively; the sum
        // is exact in double), without a libm call: 3× faster, 0.8 ms for a 512² frame.
        bytes[i] = static_cast<unsigned char>(static_cast<double>(v * 255.0f) + 0.5);
    }
    return bytes;
}

ImageRgba asWrittenToPng(const ImageRgba& image) {
    const std::vector<unsigned char> bytes = pngBytes8(image);
    ImageRgba out;
    out.width = image.width;
    out.height = image.height;
    out.rgba.resize(bytes.size());
    for (std::size_t i = 0; i < bytes.size(); ++i)
        out.rgba[i] = static_cast<float>(bytes[i]) / 255.0f;  // as readPng
    return out;
}

std::vector<unsigned char> encodePng(const ImageRgba& image, int level) {
    const std::vector<unsigned char> bytes = pngBytes8(image);
    std::vector<unsigned char> png;
    PngErrorState err;
    if (!pngWriteRgba8(nullptr, &png, level, bytes.data(), image.width, image.height, &err))
        UDVR_FAIL("cannot encode PNG: " << err.message);
    return png;
}

void writePng(const fs::path& path, const ImageRgba& image, const PngText& text) {
    const std::vector<unsigned char> bytes = pngBytes8(image);
    writeAtomically(path, [&](const fs::path& tmp) {
        errno = 0;
        std::unique_ptr<FILE, FileCloser> fp(std::fopen(tmp.c_str(), "wb"));
        if (!fp) UDVR_FILE_FAIL("cannot write " << path.string() << ": " << writeErrorText(errno));
        PngErrorState err;
        if (!pngWriteRgba8(fp.get(), nullptr, -1, bytes.data(), image.width, image.height, &err,
                           &text)) {
            // libpng says "Write Error" for a failed fwrite; errno says why.
            const std::string why = writeErrorText(errno);
            UDVR_FILE_FAIL("cannot write " << path.string() << ": "
                                           << (why.empty() ? err.message : why));
        }
        // The last buffer is written by fclose: its error counts too.
        if (std::fclose(fp.release()) != 0) {
            UDVR_FILE_FAIL("cannot write " << path.string() << ": " << writeErrorText(errno));
        }
    });
}

PngText readPngText(const fs::path& path) {
    detail::requireFile(path);
    std::unique_ptr<FILE, FileCloser> fp(std::fopen(path.c_str(), "rb"));
    if (!fp) UDVR_FILE_FAIL("cannot open " << path.string());
    unsigned char sig[8] = {};
    if (std::fread(sig, 1, 8, fp.get()) != 8 || png_sig_cmp(sig, 0, 8) != 0)
        UDVR_FAIL(path.string() << ": not a PNG file (bad signature)");
    std::rewind(fp.get());
    PngErrorState err;
    PngText out;
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &err, pngError, pngWarning);
    if (png == nullptr) UDVR_FAIL(path.string() << ": cannot read PNG");
    png_infop info = png_create_info_struct(png);
    if (info == nullptr || setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, nullptr);
        UDVR_FAIL(path.string() << ": cannot read PNG: " << err.message);
    }
    png_init_io(png, fp.get());
    png_read_info(png, info);
    png_textp chunks = nullptr;
    int count = 0;
    png_get_text(png, info, &chunks, &count);
    for (int i = 0; i < count; ++i)
        out.emplace_back(chunks[i].key, std::string(chunks[i].text, chunks[i].text_length));
    png_destroy_read_struct(&png, &info, nullptr);
    return out;
}

ImageRgba readPng(const fs::path& path) {
    detail::requireFile(path);
    std::unique_ptr<FILE, FileCloser> fp(std::fopen(path.c_str(), "rb"));
    if (!fp) UDVR_FILE_FAIL("cannot open " << path.string());
    unsigned char sig[8] = {};
    if (std::fread(sig, 1, 8, fp.get()) != 8 || png_sig_cmp(sig, 0, 8) != 0) {
        UDVR_FAIL(path.string() << ": not a PNG file (bad signature)");
    }
    std::rewind(fp.get());
    PngErrorState err;
    PngPixels px;
    if (!pngReadRgba(fp.get(), &px, &err)) {
        UDVR_FAIL(path.string() << ": cannot read PNG: " << err.message);
    }
    std::unique_ptr<unsigned char, decltype(&std::free)> owner(px.data, &std::free);
    ImageRgba image;
    image.width = px.width;
    image.height = px.height;
    image.rgba.resize(static_cast<std::size_t>(px.width) * static_cast<std::size_t>(px.height) * 4);
    for (std::size_t i = 0; i < image.rgba.size(); ++i) {
        if (px.bytesPerChannel == 1) {
            image.rgba[i] = static_cast<float>(px.data[i]) / 255.0f;
        } else {
            unsigned v = (static_cast<unsigned>(px.data[2 * i]) << 8) | px.data[2 * i + 1];
            image.rgba[i] = static_cast<float>(v) / 65535.0f;
        }
    }
    return image;
}

void writeFloatImage(const fs::path& path, const ImageRgba& image) {
    checkImage(image);
    std::string ext = detail::lowerExtension(path);
    if (ext == ".npy") return writeFileAtomically(path, npyBytes(image));
    if (ext == ".pfm") return writeFileAtomically(path, pfmBytes(image));
    UDVR_FAIL("cannot write " << path.string() << ": unknown float image format '" << ext
                              << "' (expected .npy or .pfm)");
}

ImageRgba readFloatImage(const fs::path& path) {
    std::string ext = detail::lowerExtension(path);
    if (ext == ".npy") return readNpy(path);
    if (ext == ".pfm") return readPfm(path);
    UDVR_FAIL("cannot read " << path.string() << ": unknown float image format '" << ext
                             << "' (expected .npy or .pfm)");
}

ImageRgba readImage(const fs::path& path) {
    if (detail::lowerExtension(path) == ".png") return readPng(path);
    return readFloatImage(path);
}

}  // namespace udvr
