#include "udvr/serve/api_query.h"

#include <array>
#include <cctype>
#include <cstdio>

#include "udvr/util/text_parse.h"

namespace udvr::serve {

using nlohmann::json;

const std::vector<std::string> kRenderKeys = [] {
    std::vector<std::string> keys{"model"};
    for (auto table : {classificationOptionSpecs(), frameOptionSpecs()})
        for (const OptionSpec& spec : table)
            if (spec.remote) keys.emplace_back(spec.name);
    return keys;
}();
const std::vector<std::string> kControlKeys = {"channel", "seq", "page", "source", "format"};

ApiResponse jsonResponse(const json& body, int status) {
    ApiResponse r;
    r.status = status;
    r.body = body.dump(-1, ' ', false, json::error_handler_t::replace);  // bad UTF-8 → U+FFFD
    return r;
}

ApiResponse errorResponse(int status, const std::string& message) {
    return jsonResponse(json{{"error", message}}, status);
}

std::string pngHeaderSafe(double v) {
    char text[64];
    std::snprintf(text, sizeof text, "%.10g", v);
    return text;
}

bool isToken(const std::string& s) {
    if (s.empty() || s.size() > 32) return false;
    for (char c : s)
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_')) return false;
    return true;
}

RenderOptions renderOptionsOf(const Query& q) {
    RenderOptions f;
    for (auto table : {classificationOptionSpecs(), frameOptionSpecs()})
        for (const OptionSpec& spec : table)
            if (const std::string* v = spec.remote ? q.find(spec.name) : nullptr)
                setOption(f, spec, *v, spec.name);
    std::array<int, 2> size{};
    try {
        size = parseSize(f.size, "size");
    } catch (const UdvrError&) {
        size = {kMaxImageSide + 1, 0};  // the message below says what is allowed
    }
    if (size[0] > kMaxImageSide || size[1] > kMaxImageSide || size[1] < 1)
        UDVR_FAIL("size must be WxH between 1x1 and " << kMaxImageSide << "x" << kMaxImageSide
                                                      << ", got '" << Query::clip(f.size) << "'");
    if (f.realizations > static_cast<std::uint64_t>(kMaxRealizations))
        UDVR_FAIL("realizations must be a whole number in [1, " << kMaxRealizations << "], got "
                                                                << f.realizations);
    checkRenderOptions(f);
    return f;
}

}  // namespace udvr::serve
