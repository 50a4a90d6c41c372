// 2D transfer-function files (SPEC §9): .npy rasters here; widget JSON in the core
// (classify/transfer_function_2d_widget_json.cpp); .vti rasters in vti_io.cpp with the rest of
// the VTK code.
#include "udvr/io/transfer_function_2d_io.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>

#include "udvr/io/io_detail.h"
#include "udvr/io/npy.h"
#include "udvr/util/atomic_file.h"
#include "udvr/util/check.h"

namespace udvr {
namespace fs = std::filesystem;

namespace {

std::string readAll(const fs::path& path) {
    detail::requireFile(path);
    std::ifstream in(path, std::ios::binary);
    if (!in) UDVR_FILE_FAIL("cannot open " << path.string());
    std::ostringstream ss;
    ss << in.rdbuf();
    if (in.bad()) UDVR_FILE_FAIL("cannot read " << path.string());
    return ss.str();
}

// ---- .npy rasters ---------------------------------------------------------------------------

TransferFunction2D readNpyRaster(const fs::path& path, const Tf2ReadOptions& options) {
    const std::string what = path.string();
    const std::string bytes = readAll(path);
    const NpyHeader h = parseNpyHeader(bytes, what);
    int itemSize = 0;
    std::string d = h.descr;
    if (d == "u1" || d == "<u1" || d == "=u1") d = "|u1";  // one byte has no byte order
    if (d == "<f4")
        itemSize = 4;
    else if (d == "<f8")
        itemSize = 8;
    else if (d == "|u1")
        itemSize = 1;
    else if (!d.empty() && d[0] == '>')
        UDVR_FAIL(what << ": NPY dtype '" << h.descr
                       << "' is big-endian; expected '<f4', '<f8' or '|u1' (little-endian)");
    else
        UDVR_FAIL(what << ": NPY dtype '" << h.descr << "' unsupported (expected '<f4', '<f8' or "
                       << "'|u1')");
    if (h.fortranOrder)
        UDVR_FAIL(
            what << ": NPY fortran_order is True; expected C order (numpy.ascontiguousarray)");
    if (h.shape.size() != 3 || h.shape[2] != 4 || h.shape[0] < 2 || h.shape[1] < 2 ||
        h.shape[0] > kMaxTf2Resolution || h.shape[1] > kMaxTf2Resolution) {
        std::string shape;
        for (long long s : h.shape) shape += (shape.empty() ? "" : ", ") + std::to_string(s);
        UDVR_FAIL(what << ": NPY shape (" << shape << ") unsupported (expected (H, W, 4) with "
                       << "2 <= H, W <= " << kMaxTf2Resolution << ")");
    }
    const std::size_t expected = h.elementCount() * static_cast<std::size_t>(itemSize);
    const std::size_t actual = bytes.size() - h.dataOffset;
    if (actual != expected)
        UDVR_FAIL(what << (actual < expected ? ": truncated NPY data"
                                             : ": NPY shape does not match the data")
                       << ": expected " << expected << " bytes, found " << actual);
    if (!options.domain)
        UDVR_FAIL(what << ": a .npy 2D transfer function carries no domain; give x0,x1,y0,y1 "
                          "(--tf2-domain)");
    checkTf2Domain(*options.domain, what);
    if (options.resolution)
        UDVR_FAIL(what << ": a resolution applies to widget (.json) files only; this raster has "
                       << h.shape[1] << "x" << h.shape[0] << " points");

    TransferFunction2D tf;
    tf.height = static_cast<int>(h.shape[0]);
    tf.width = static_cast<int>(h.shape[1]);
    tf.x0 = (*options.domain)[0];
    tf.x1 = (*options.domain)[1];
    tf.y0 = (*options.domain)[2];
    tf.y1 = (*options.domain)[3];
    tf.rgba.resize(h.elementCount());
    const char* data = bytes.data() + h.dataOffset;
    for (std::size_t k = 0; k < tf.rgba.size(); ++k) {
        const char* p = data + k * static_cast<std::size_t>(itemSize);
        const double v = itemSize == 4   ? loadLittle<float>(p)
                         : itemSize == 8 ? loadLittle<double>(p)
                                         : static_cast<unsigned char>(*p) / 255.0;
        if (!std::isfinite(v))
            UDVR_FAIL(what << ": non-finite value " << v << " at row " << k / 4 / tf.width
                           << ", column " << k / 4 % tf.width << ", channel " << k % 4
                           << "; expected values in [0, 1]");
        tf.rgba[k] = static_cast<float>(v);
    }
    try {
        tf.validate();
    } catch (const UdvrError& e) {
        UDVR_FAIL(what << ": " << e.what());
    }
    return tf;
}

}  // namespace

TransferFunction2D readTransferFunction2D(const fs::path& path, const Tf2ReadOptions& options) {
    const std::string ext = detail::lowerExtension(path);
    if (ext == ".json") return transferFunction2DFromWidgets(readAll(path), path.string(), options);
    if (ext == ".npy") return readNpyRaster(path, options);
    if (ext == ".vti") {
        if (options.domain)
            UDVR_FAIL(path.string() << ": a .vti 2D transfer function carries its domain (origin "
                                       "and spacing); do not give one (--tf2-domain)");
        if (options.resolution)
            UDVR_FAIL(
                path.string()
                << ": a resolution applies to widget (.json) files only, not to a .vti raster");
        return detail::readTransferFunction2DVti(path);
    }
    UDVR_FAIL("2D transfer function '" << path.string() << "': unknown extension '"
                                       << path.extension().string()
                                       << "' (expected .vti, .npy or .json)");
}

void writeTransferFunction2DNpy(const fs::path& path, const TransferFunction2D& tf) {
    tf.validate();
    std::string bytes = npyHeaderBytes("<f4", {tf.height, tf.width, 4});
    bytes.reserve(bytes.size() + tf.rgba.size() * sizeof(float));
    for (float v : tf.rgba) {
        unsigned char b[sizeof(float)];
        std::memcpy(b, &v, sizeof(float));
        if constexpr (std::endian::native == std::endian::big) std::reverse(b, b + sizeof(float));
        bytes.append(reinterpret_cast<const char*>(b), sizeof(float));
    }
    writeFileAtomically(path, bytes);
}

void writeTransferFunction2D(const fs::path& path, const TransferFunction2D& tf) {
    const std::string ext = detail::lowerExtension(path);
    if (ext == ".vti") return writeTransferFunction2DVti(path, tf);
    if (ext == ".npy") return writeTransferFunction2DNpy(path, tf);
    UDVR_FAIL("cannot write 2D transfer function '" << path.string()
                                                    << "': expected a .vti or .npy file name");
}

}  // namespace udvr
