// 2D transfer-function files (SPEC §9): .npy rasters and widget JSON here; .vti rasters in
// vti_io.cpp with the rest of the VTK code.
#include "udvr/io/transfer_function_2d_io.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <type_traits>
#include <variant>

#include "udvr/io/io_detail.h"
#include "udvr/io/npy.h"
#include "udvr/util/atomic_file.h"
#include "udvr/util/check.h"

namespace udvr {
namespace fs = std::filesystem;

namespace {

using nlohmann::json;

std::string readAll(const fs::path& path) {
    detail::requireFile(path);
    std::ifstream in(path, std::ios::binary);
    if (!in) UDVR_FILE_FAIL("cannot open " << path.string());
    std::ostringstream ss;
    ss << in.rdbuf();
    if (in.bad()) UDVR_FILE_FAIL("cannot read " << path.string());
    return ss.str();
}

/// Throws unless the domain is finite and non-empty along both axes.
void checkDomain(const std::array<double, 4>& d, const std::string& what) {
    for (double v : d)
        if (!std::isfinite(v))
            UDVR_FAIL(what << ": the domain must be finite, got [" << d[0] << ", " << d[1]
                           << "] x [" << d[2] << ", " << d[3] << "]");
    if (!(d[0] < d[1]) || !(d[2] < d[3]))
        UDVR_FAIL(what << ": empty domain [" << d[0] << ", " << d[1] << "] x [" << d[2] << ", "
                       << d[3] << "] (expected x0 < x1 and y0 < y1)");
}

void checkResolution(const std::array<int, 2>& r, const std::string& what) {
    if (r[0] < 2 || r[1] < 2 || r[0] > kMaxTf2Resolution || r[1] > kMaxTf2Resolution)
        UDVR_FAIL(what << ": resolution " << r[0] << "x" << r[1] << " out of range (2 to "
                       << kMaxTf2Resolution << " points per axis)");
}

// ---- widget JSON ----------------------------------------------------------------------------

/// Where we are in the file, for error messages: "FILE: widget 2 (band)".
struct Context {
    const std::string& what;
    std::string where;  // "" at the top level
    std::string prefix() const { return where.empty() ? what : what + ": " + where; }
};

double finiteNumber(const json& v, const Context& c, const std::string& key) {
    if (!v.is_number()) UDVR_FAIL(c.prefix() << ": '" << key << "' must be a number");
    const double d = v.get<double>();
    if (!std::isfinite(d)) UDVR_FAIL(c.prefix() << ": '" << key << "' must be finite");
    return d;
}

const json& required(const json& obj, const Context& c, const char* key) {
    const auto it = obj.find(key);
    if (it == obj.end()) UDVR_FAIL(c.prefix() << ": missing key '" << key << "'");
    return *it;
}

template <std::size_t N>
std::array<double, N> numberArray(const json& v, const Context& c, const std::string& key) {
    if (!v.is_array() || v.size() != N)
        UDVR_FAIL(c.prefix() << ": '" << key << "' must be an array of " << N << " numbers");
    std::array<double, N> out{};
    for (std::size_t k = 0; k < N; ++k)
        out[k] = finiteNumber(v[k], c, key + "[" + std::to_string(k) + "]");
    return out;
}

std::string stringValue(const json& v, const Context& c, const std::string& key) {
    if (!v.is_string()) UDVR_FAIL(c.prefix() << ": '" << key << "' must be a string");
    return v.get<std::string>();
}

/// Throws naming the first key of `obj` that is not in `allowed`.
void checkKeys(const json& obj, const Context& c, std::initializer_list<const char*> allowed) {
    const std::set<std::string> ok(allowed.begin(), allowed.end());
    for (auto it = obj.begin(); it != obj.end(); ++it)
        if (!ok.count(it.key())) {
            std::string list;
            for (const char* k : allowed) list += (list.empty() ? "" : ", ") + std::string(k);
            UDVR_FAIL(c.prefix() << ": unknown key '" << it.key() << "' (expected " << list << ")");
        }
}

/// An ordered pair lo ≤ hi.
std::array<double, 2> range(const json& obj, const Context& c, const char* key) {
    const auto r = numberArray<2>(required(obj, c, key), c, key);
    if (r[0] > r[1])
        UDVR_FAIL(c.prefix() << ": '" << key << "' must be [low, high], got [" << r[0] << ", "
                             << r[1] << "]");
    return r;
}

double positive(const json& obj, const Context& c, const char* key) {
    const double v = finiteNumber(required(obj, c, key), c, key);
    if (!(v > 0.0)) UDVR_FAIL(c.prefix() << ": '" << key << "' must be > 0, got " << v);
    return v;
}

Tf2Widget parseWidget(const json& w, const Context& c) {
    if (!w.is_object()) UDVR_FAIL(c.prefix() << ": expected an object with \"type\" and \"rgba\"");
    const std::string type = stringValue(required(w, c, "type"), c, "type");
    const Context wc{c.what, c.where + " (" + type + ")"};
    Tf2Widget out;
    out.rgba = numberArray<4>(required(w, wc, "rgba"), wc, "rgba");
    for (std::size_t k = 0; k < 4; ++k)
        if (out.rgba[k] < 0.0 || out.rgba[k] > 1.0)
            UDVR_FAIL(wc.prefix() << ": 'rgba' values must lie in [0, 1], got " << out.rgba[k]
                                  << " at index " << k);
    if (type == "box") {
        checkKeys(w, wc, {"type", "rgba", "name", "comment", "x", "y"});
        Tf2Box b;
        b.x = range(w, wc, "x");
        b.y = range(w, wc, "y");
        out.shape = b;
    } else if (type == "triangle") {
        checkKeys(w, wc, {"type", "rgba", "name", "comment", "apex", "top", "width", "falloff"});
        Tf2Triangle t;
        t.apex = numberArray<2>(required(w, wc, "apex"), wc, "apex");
        t.top = finiteNumber(required(w, wc, "top"), wc, "top");
        if (t.top == t.apex[1])
            UDVR_FAIL(wc.prefix() << ": 'top' must differ from the apex's y (" << t.apex[1] << ")");
        t.width = positive(w, wc, "width");
        if (w.contains("falloff")) {
            const std::string f = stringValue(w["falloff"], wc, "falloff");
            if (f != "tent" && f != "flat")
                UDVR_FAIL(wc.prefix()
                          << ": 'falloff' must be \"tent\" or \"flat\", got \"" << f << "\"");
            t.flat = f == "flat";
        }
        out.shape = t;
    } else if (type == "ellipse") {
        checkKeys(w, wc, {"type", "rgba", "name", "comment", "center", "sigma", "angle", "cutoff"});
        Tf2Ellipse e;
        e.center = numberArray<2>(required(w, wc, "center"), wc, "center");
        e.sigma = numberArray<2>(required(w, wc, "sigma"), wc, "sigma");
        if (!(e.sigma[0] > 0.0 && e.sigma[1] > 0.0))
            UDVR_FAIL(wc.prefix() << ": 'sigma' values must be > 0, got [" << e.sigma[0] << ", "
                                  << e.sigma[1] << "]");
        // Reduced to (-360, 360) exactly: the rasteriser's angle·π/180 overflows past 5.7e305
        // (an angle of 1e308 drew NaN, reported as a colour out of [0, 1]; issue 34).
        if (w.contains("angle"))
            e.angleDeg = std::fmod(finiteNumber(w["angle"], wc, "angle"), 360.0);
        if (w.contains("cutoff")) e.cutoff = positive(w, wc, "cutoff");
        out.shape = e;
    } else if (type == "band") {
        checkKeys(w, wc, {"type", "rgba", "name", "comment", "points", "half_width", "profile"});
        Tf2Band b;
        const json& pts = required(w, wc, "points");
        if (!pts.is_array() || pts.empty())
            UDVR_FAIL(wc.prefix() << ": 'points' must be a non-empty array of [x, y] pairs");
        for (std::size_t k = 0; k < pts.size(); ++k)
            b.points.push_back(numberArray<2>(pts[k], wc, "points[" + std::to_string(k) + "]"));
        b.halfWidth = numberArray<2>(required(w, wc, "half_width"), wc, "half_width");
        if (!(b.halfWidth[0] > 0.0 && b.halfWidth[1] > 0.0))
            UDVR_FAIL(wc.prefix() << ": 'half_width' values must be > 0, got [" << b.halfWidth[0]
                                  << ", " << b.halfWidth[1] << "]");
        if (w.contains("profile")) {
            const std::string p = stringValue(w["profile"], wc, "profile");
            if (p != "box" && p != "tent")
                UDVR_FAIL(wc.prefix()
                          << ": 'profile' must be \"box\" or \"tent\", got \"" << p << "\"");
            b.tent = p == "tent";
        }
        out.shape = b;
    } else {
        UDVR_FAIL(c.prefix() << ": unknown type \"" << type
                             << "\" (expected box, triangle, ellipse or band)");
    }
    return out;
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
    checkDomain(*options.domain, what);
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

Tf2WidgetFile parseTf2Widgets(const std::string& text, const std::string& what) {
    json doc;
    try {
        doc = json::parse(text);
    } catch (const json::exception& e) {
        std::string msg = e.what();
        for (char& ch : msg)
            if (ch == '\n') ch = ' ';
        UDVR_FAIL(what << ": not valid JSON (" << msg << ")");
    }
    const Context top{what, ""};
    if (!doc.is_object())
        UDVR_FAIL(
            what << ": expected an object {\"domain\": [x0, x1, y0, y1], \"widgets\": [...]}");
    checkKeys(doc, top, {"domain", "resolution", "widgets", "name", "comment"});
    Tf2WidgetFile out;
    if (doc.contains("domain")) {
        out.domain = numberArray<4>(doc["domain"], top, "domain");
        checkDomain(*out.domain, what);
    }
    if (doc.contains("resolution")) {
        const json& r = doc["resolution"];
        if (!r.is_array() || r.size() != 2 || !r[0].is_number_integer() ||
            !r[1].is_number_integer())
            UDVR_FAIL(what << ": 'resolution' must be [W, H], two whole numbers");
        const long long w = r[0].get<long long>(), h = r[1].get<long long>();
        if (w < 2 || h < 2 || w > kMaxTf2Resolution || h > kMaxTf2Resolution)
            UDVR_FAIL(what << ": 'resolution' " << w << "x" << h << " out of range (2 to "
                           << kMaxTf2Resolution << " points per axis)");
        out.resolution = std::array<int, 2>{static_cast<int>(w), static_cast<int>(h)};
    }
    const json& widgets = required(doc, top, "widgets");
    if (!widgets.is_array()) UDVR_FAIL(what << ": 'widgets' must be an array");
    for (std::size_t k = 0; k < widgets.size(); ++k)
        out.widgets.push_back(
            parseWidget(widgets[k], Context{what, "widget " + std::to_string(k)}));
    return out;
}

double tf2WidgetWork(const std::vector<Tf2Widget>& widgets, int width, int height) {
    double perPoint = 0;  // widget evaluations per raster point
    for (const Tf2Widget& w : widgets)
        perPoint += std::visit(
            [](const auto& s) -> double {
                if constexpr (std::is_same_v<std::decay_t<decltype(s)>, Tf2Band>)
                    return static_cast<double>(std::max<std::size_t>(s.points.size(), 2) - 1);
                return 1.0;
            },
            w.shape);
    return perPoint * width * height;
}

TransferFunction2D transferFunction2DFromWidgets(const std::string& text, const std::string& what,
                                                 const Tf2ReadOptions& options) {
    const Tf2WidgetFile file = parseTf2Widgets(text, what);
    std::array<double, 4> domain{};
    if (options.domain)
        domain = *options.domain;
    else if (file.domain)
        domain = *file.domain;
    else
        UDVR_FAIL(what << ": missing key 'domain' [x0, x1, y0, y1] (or give --tf2-domain)");
    checkDomain(domain, what);
    const std::array<int, 2> resolution = options.resolution
                                              ? *options.resolution
                                              : file.resolution.value_or(std::array<int, 2>{
                                                    kDefaultTf2Resolution, kDefaultTf2Resolution});
    checkResolution(resolution, what);
    const double work = tf2WidgetWork(file.widgets, resolution[0], resolution[1]);
    if (work > kMaxTf2WidgetWorkWithoutForce && !options.force)
        UDVR_FAIL(what << ": rasterising " << file.widgets.size() << " widgets onto "
                       << resolution[0] << "x" << resolution[1] << " points takes " << work
                       << " widget evaluations (band segments count one each), over "
                       << kMaxTf2WidgetWorkWithoutForce
                       << "; lower the resolution (--tf2-resolution) or add --force");
    try {
        return rasterizeWidgets(file.widgets, resolution[0], resolution[1], domain);
    } catch (const UdvrError& e) {
        UDVR_FAIL(what << ": " << e.what());
    }
}

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
