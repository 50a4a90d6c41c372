#include "udvr/classify/transfer_function_2d_widget_json.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <type_traits>
#include <variant>

#include "udvr/util/check.h"
#include "udvr/util/json_text.h"

namespace udvr {

void checkTf2Domain(const std::array<double, 4>& d, const std::string& what) {
    for (double v : d)
        if (!std::isfinite(v))
            UDVR_FAIL(what << ": the domain must be finite, got [" << d[0] << ", " << d[1]
                           << "] x [" << d[2] << ", " << d[3] << "]");
    if (!(d[0] < d[1]) || !(d[2] < d[3]))
        UDVR_FAIL(what << ": empty domain [" << d[0] << ", " << d[1] << "] x [" << d[2] << ", "
                       << d[3] << "] (expected x0 < x1 and y0 < y1)");
}

void checkTf2Resolution(const std::array<int, 2>& r, const std::string& what) {
    if (r[0] < 2 || r[1] < 2 || r[0] > kMaxTf2Resolution || r[1] > kMaxTf2Resolution)
        UDVR_FAIL(what << ": resolution " << r[0] << "x" << r[1] << " out of range (2 to "
                       << kMaxTf2Resolution << " points per axis)");
}

namespace {

using nlohmann::json;

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

/// An optional key naming one of two choices: whether it names `second` (absent: `first`).
bool isSecondChoice(const json& w, const Context& c, const char* key, const char* first,
                    const char* second) {
    if (!w.contains(key)) return false;
    const std::string v = stringValue(w[key], c, key);
    if (v != first && v != second)
        UDVR_FAIL(c.prefix() << ": '" << key << "' must be \"" << first << "\" or \"" << second
                             << "\", got \"" << v << "\"");
    return v == second;
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
        t.flat = isSecondChoice(w, wc, "falloff", "tent", "flat");
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
        b.tent = isSecondChoice(w, wc, "profile", "box", "tent");
        out.shape = b;
    } else {
        UDVR_FAIL(c.prefix() << ": unknown type \"" << type
                             << "\" (expected box, triangle, ellipse or band)");
    }
    return out;
}

}  // namespace

Tf2WidgetFile parseTf2Widgets(const std::string& text, const std::string& what) {
    json doc = parseJsonText(text, what);
    const Context top{what, ""};
    if (!doc.is_object())
        UDVR_FAIL(
            what << ": expected an object {\"domain\": [x0, x1, y0, y1], \"widgets\": [...]}");
    checkKeys(doc, top, {"domain", "resolution", "widgets", "name", "comment"});
    Tf2WidgetFile out;
    if (doc.contains("domain")) {
        out.domain = numberArray<4>(doc["domain"], top, "domain");
        checkTf2Domain(*out.domain, what);
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
    checkTf2Domain(domain, what);
    const std::array<int, 2> resolution = options.resolution
                                              ? *options.resolution
                                              : file.resolution.value_or(std::array<int, 2>{
                                                    kDefaultTf2Resolution, kDefaultTf2Resolution});
    checkTf2Resolution(resolution, what);
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

}  // namespace udvr
