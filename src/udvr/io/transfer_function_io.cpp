// ParaView transfer-function JSON (SPEC §7).
#include "udvr/io/transfer_function_io.h"

#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "udvr/util/check.h"
#include "udvr/util/json_text.h"

namespace udvr {
namespace {

using nlohmann::json;

// The numbers of array `key` of `obj`; throws naming the source when it is not a number list.
std::vector<double> numberArray(const json& obj, const char* key, const std::string& what) {
    const json& a = obj.at(key);
    if (!a.is_array()) UDVR_FAIL(what << ": '" << key << "' must be an array of numbers");
    std::vector<double> v;
    v.reserve(a.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
        if (!a[i].is_number())
            UDVR_FAIL(what << ": '" << key << "' entry " << i << " is not a number");
        v.push_back(a[i].get<double>());
    }
    return v;
}

}  // namespace

TransferFunction1D parseTransferFunction(const std::string& text, const std::string& what) {
    json doc = parseJsonText(text, what);
    // A list of objects (ParaView's preset files) or one bare object; the first object with
    // RGBPoints is used.
    const json* obj = nullptr;
    if (doc.is_array()) {
        for (const json& e : doc)
            if (e.is_object() && e.contains("RGBPoints")) {
                obj = &e;
                break;
            }
        if (!obj && !doc.empty() && doc[0].is_object()) obj = &doc[0];
    } else if (doc.is_object()) {
        obj = &doc;
    }
    if (!obj)
        UDVR_FAIL(what << ": expected a ParaView transfer function (a list of objects or one "
                          "object with \"RGBPoints\" and \"Points\")");
    if (!obj->contains("RGBPoints")) {
        if (obj->contains("widgets"))  // a 2D TF's widget file (docs/formats.md)
            UDVR_FAIL(what << " is a 2D transfer function (widgets): pass it with --tf2, not --tf");
        UDVR_FAIL(what << ": no \"RGBPoints\" [x,r,g,b,...] array");
    }

    TransferFunction1D tf;
    // Notes and warnings are printed once the whole function is valid: an error stays the one
    // line on stderr.
    std::vector<std::string> notes;
    const std::vector<double> rgb = numberArray(*obj, "RGBPoints", what);
    if (rgb.empty() || rgb.size() % 4 != 0)
        UDVR_FAIL(what << ": \"RGBPoints\" needs groups of 4 numbers (x,r,g,b), got "
                       << rgb.size());
    for (std::size_t i = 0; i < rgb.size(); i += 4) {
        tf.colorX.push_back(rgb[i]);
        tf.color.push_back({rgb[i + 1], rgb[i + 2], rgb[i + 3]});
    }
    if (obj->contains("Points")) {
        const std::vector<double> pts = numberArray(*obj, "Points", what);
        if (pts.empty() || pts.size() % 4 != 0)
            UDVR_FAIL(what << ": \"Points\" needs groups of 4 numbers (x,alpha,midpoint,"
                              "sharpness), got "
                           << pts.size());
        bool ignored = false;
        for (std::size_t i = 0; i < pts.size(); i += 4) {
            tf.opacityX.push_back(pts[i]);
            tf.opacity.push_back(pts[i + 1]);
            if (pts[i + 2] != 0.5 || pts[i + 3] != 0.0) ignored = true;
        }
        if (ignored)
            notes.push_back("udvr: warning: " + what +
                            ": opacity midpoint/sharpness other than 0.5/0 are ignored (opacity "
                            "is piecewise linear between points)");
    } else {
        // ParaView's default opacity: a linear ramp 0 → 1 over the colour range.
        tf.opacityX = {tf.colorX.front(), tf.colorX.back()};
        tf.opacity = {0.0, 1.0};
        std::ostringstream note;
        note << "udvr: note: " << what << ": no \"Points\"; opacity is a linear ramp 0..1 over ["
             << tf.colorX.front() << ", " << tf.colorX.back() << "]";
        notes.push_back(note.str());
    }
    if (obj->contains("ColorSpace") && (*obj)["ColorSpace"].is_string() &&
        (*obj)["ColorSpace"].get<std::string>() != "RGB")
        notes.push_back("udvr: note: " + what + ": colours are interpolated in RGB (ColorSpace '" +
                        (*obj)["ColorSpace"].get<std::string>() + "' ignored)");
    try {
        tf.validate();
    } catch (const UdvrError& e) {
        UDVR_FAIL(what << ": " << e.what());
    }
    for (const std::string& note : notes)
        std::fprintf(stderr, "%s\n", detail::printableLine(note).c_str());
    return tf;
}

TransferFunction1D readTransferFunction(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) UDVR_FILE_FAIL("cannot open transfer function '" << path.string() << "'");
    std::ostringstream ss;
    ss << in.rdbuf();
    if (in.bad()) UDVR_FILE_FAIL("cannot read transfer function '" << path.string() << "'");
    return parseTransferFunction(ss.str(), path.string());
}

std::string transferFunctionToJson(const TransferFunction1D& tf, const std::string& name) {
    json rgb = json::array(), pts = json::array();
    for (std::size_t i = 0; i < tf.colorX.size(); ++i) {
        rgb.push_back(tf.colorX[i]);
        for (double c : tf.color[i]) rgb.push_back(c);
    }
    for (std::size_t i = 0; i < tf.opacityX.size(); ++i) {
        pts.push_back(tf.opacityX[i]);
        pts.push_back(tf.opacity[i]);
        pts.push_back(0.5);
        pts.push_back(0.0);
    }
    json obj = {{"Name", name}, {"ColorSpace", "RGB"}, {"RGBPoints", rgb}, {"Points", pts}};
    return json::array({obj}).dump(2) + "\n";
}

}  // namespace udvr
