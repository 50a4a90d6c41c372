#pragma once
// What the endpoints of `udvr serve`'s API share (internal to serve/: api.cpp, the state and the
// dispatch; api_render.cpp, renders and probes; api_tf.cpp, the TFs and histograms): the
// query's keys, its parsing and checks, and the JSON answers.
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "udvr/classify/transfer_function_2d.h"
#include "udvr/render/render_options.h"
#include "udvr/serve/api.h"
#include "udvr/util/check.h"

namespace udvr::serve {

// The /api/render parameters that choose the image: "model" and every option of the library's
// tables that a server takes (render/render_options.h), by the names of `udvr render`'s flags.
extern const std::vector<std::string> kRenderKeys;
// Parameters that steer the request, not the image.
extern const std::vector<std::string> kControlKeys;

ApiResponse jsonResponse(const nlohmann::json& body, int status = 200);
ApiResponse errorResponse(int status, const std::string& message);

// The query as a map, each key at most once and from `allowed`, values of bounded length.
class Query {
  public:
    Query(const std::vector<std::pair<std::string, std::string>>& params,
          const std::vector<std::vector<std::string>>& allowed) {
        for (const auto& [key, value] : params) {
            bool known = false;
            for (const auto& list : allowed)
                known = known || std::find(list.begin(), list.end(), key) != list.end();
            if (!known) {
                std::string names;
                for (const auto& list : allowed)
                    for (const auto& k : list) names += (names.empty() ? "" : ", ") + k;
                UDVR_FAIL("unknown parameter '" << clip(key) << "' (expected: " << names << ")");
            }
            if (value.size() > kMaxValueChars)
                UDVR_FAIL("parameter '" << key << "' is longer than " << kMaxValueChars
                                        << " characters");
            if (!values_.emplace(key, value).second)
                UDVR_FAIL("parameter '" << key << "' is given twice");
        }
    }
    const std::string* find(const std::string& key) const {
        const auto it = values_.find(key);
        return it == values_.end() ? nullptr : &it->second;
    }
    bool has(const std::string& key) const { return values_.count(key) > 0; }
    std::string text(const std::string& key, const std::string& fallback = "") const {
        const std::string* v = find(key);
        return v ? *v : fallback;
    }
    /// A finite number in [lo, hi] (lo/hi exclusive when the flags say so).
    std::optional<double> number(const std::string& key, double lo, double hi,
                                 bool loOpen = false) const {
        const std::string* v = find(key);
        if (!v) return std::nullopt;
        char* end = nullptr;
        const double x = std::strtod(v->c_str(), &end);
        if (v->empty() || end != v->c_str() + v->size() || !std::isfinite(x))
            UDVR_FAIL(key << ": '" << clip(*v) << "' is not a finite number");
        if (x > hi || x < lo || (loOpen && x == lo))
            UDVR_FAIL(key << " must lie in " << (loOpen ? "(" : "[") << lo << ", " << hi
                          << "], got " << *v);
        return x;
    }
    /// A whole number in [lo, hi].
    std::optional<std::uint64_t> whole(const std::string& key, std::uint64_t lo,
                                       std::uint64_t hi) const {
        const std::string* v = find(key);
        if (!v) return std::nullopt;
        errno = 0;
        char* end = nullptr;
        const unsigned long long x = std::strtoull(v->c_str(), &end, 10);
        if (v->empty() || (*v)[0] == '-' || end != v->c_str() + v->size() || errno == ERANGE ||
            x < lo || x > hi)
            UDVR_FAIL(key << ": '" << clip(*v) << "' is not a whole number in [" << lo << ", " << hi
                          << "]");
        return x;
    }
    /// Every key of `keys` that is present, as key=value&… in the order of `keys`.
    std::string canonical(const std::vector<std::string>& keys) const {
        std::string out;
        for (const auto& k : keys)
            if (const std::string* v = find(k)) out += k + "=" + *v + "&";
        return out;
    }
    static std::string clip(const std::string& s) {
        return s.size() > 40 ? s.substr(0, 40) + "..." : s;
    }

  private:
    std::map<std::string, std::string> values_;
};

std::string pngHeaderSafe(double v);
// "a-z0-9_-", 1–32 characters: channel names.
bool isToken(const std::string& s);
// The RenderOptions of a query: each option of the library's tables by its name, parsed and
// range-checked as the CLI's flags are, then the server's own caps (size, realizations).
RenderOptions renderOptionsOf(const Query& q);
// Widget JSON as `udvr render --tf2` reads it, with the raster's domain and resolution written
// in (they may have come from --tf2-domain or --tf2-resolution, or the default resolution).
std::string completeWidgetJson(const std::string& text, const std::string& what,
                               const TransferFunction2D& tf);

}  // namespace udvr::serve
