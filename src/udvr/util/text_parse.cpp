#include "udvr/util/text_parse.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>

#include "udvr/util/check.h"

namespace udvr {
namespace {

std::vector<std::string> split(const std::string& text, char sep) {
    std::vector<std::string> parts;
    std::string cur;
    for (char c : text) {
        if (c == sep) {
            parts.push_back(cur);
            cur.clear();
        } else {
            cur += c;
        }
    }
    parts.push_back(cur);
    return parts;
}

long toInt(const std::string& s, const std::string& flag) {
    char* end = nullptr;
    errno = 0;
    long v = std::strtol(s.c_str(), &end, 10);
    if (s.empty() || end == s.c_str() || *end != '\0' || errno == ERANGE)
        UDVR_FAIL(flag << ": '" << clipForMessage(s) << "' is not a whole number");
    return v;
}

}  // namespace

std::string clipForMessage(std::string_view text) {
    constexpr std::size_t kMax = 64;
    return text.size() <= kMax ? std::string(text) : std::string(text.substr(0, kMax)) + "...";
}

double parseReal(const std::string& s, const std::string& flag) {
    char* end = nullptr;
    double v = std::strtod(s.c_str(), &end);
    if (s.empty() || end == s.c_str() || *end != '\0' || !std::isfinite(v))
        UDVR_FAIL(flag << ": '" << clipForMessage(s) << "' is not a finite number");
    return v;
}

std::uint64_t parseWhole(const std::string& s, const std::string& flag, std::uint64_t lo,
                         std::uint64_t hi) {
    bool digits = !s.empty();
    for (char c : s) digits = digits && c >= '0' && c <= '9';
    errno = 0;
    const std::uint64_t v = digits ? std::strtoull(s.c_str(), nullptr, 10) : 0;
    if (!digits || errno == ERANGE || v < lo || v > hi)
        UDVR_FAIL(flag << " must be a whole number in [" << lo << ", " << hi << "], got '"
                       << clipForMessage(s) << "'");
    return v;
}

bool parseBool(const std::string& s, const std::string& flag) {
    if (s == "1" || s == "true" || s == "yes" || s == "on") return true;
    if (s == "0" || s == "false" || s == "no" || s == "off") return false;
    UDVR_FAIL(flag << " must be 1 or 0 (true or false), got '" << clipForMessage(s) << "'");
}

std::array<int, 3> parseDims(const std::string& text, const std::string& flag) {
    auto parts = split(text, ',');
    if (parts.size() != 1 && parts.size() != 3)
        UDVR_FAIL(flag << " expects N or X,Y,Z, got '" << clipForMessage(text) << "'");
    std::array<int, 3> d{};
    for (int a = 0; a < 3; ++a) {
        long v = toInt(parts[parts.size() == 1 ? 0 : static_cast<std::size_t>(a)], flag);
        if (v < 1 || v > 65536) UDVR_FAIL(flag << " values must lie in [1, 65536], got " << v);
        d[static_cast<std::size_t>(a)] = static_cast<int>(v);
    }
    return d;
}

std::array<double, 3> parseVec3(const std::string& text, const std::string& flag) {
    auto parts = split(text, ',');
    if (parts.size() != 3)
        UDVR_FAIL(flag << " expects x,y,z, got '" << clipForMessage(text) << "'");
    return {parseReal(parts[0], flag), parseReal(parts[1], flag), parseReal(parts[2], flag)};
}

std::array<int, 2> parseSize(const std::string& text, const std::string& flag, int maxSide) {
    auto parts = split(text, 'x');
    if (parts.size() != 1 && parts.size() != 2)
        UDVR_FAIL(flag << " expects WxH, got '" << clipForMessage(text) << "'");
    long w = toInt(parts[0], flag);
    long h = parts.size() == 2 ? toInt(parts[1], flag) : w;
    if (w < 1 || h < 1 || w > maxSide || h > maxSide)
        UDVR_FAIL(flag << " must be between 1x1 and " << maxSide << "x" << maxSide << ", got '"
                       << clipForMessage(text) << "'");
    return {static_cast<int>(w), static_cast<int>(h)};
}

std::vector<double> parseDoubleList(const std::string& text, const std::string& flag) {
    std::vector<double> out;
    for (const auto& p : split(text, ',')) out.push_back(parseReal(p, flag));
    return out;
}

namespace {

std::string foldedName(std::string_view s) {
    std::string out;
    for (char c : s) {
        if (c == '_') c = '-';
        out += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    }
    return out;
}

/// Optimal string alignment distance (Levenshtein with adjacent swaps).
std::size_t editDistance(const std::string& a, const std::string& b) {
    const std::size_t n = a.size(), m = b.size();
    std::vector<std::vector<std::size_t>> d(n + 1, std::vector<std::size_t>(m + 1, 0));
    for (std::size_t i = 0; i <= n; ++i) d[i][0] = i;
    for (std::size_t j = 0; j <= m; ++j) d[0][j] = j;
    for (std::size_t i = 1; i <= n; ++i)
        for (std::size_t j = 1; j <= m; ++j) {
            const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
            d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
            if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
                d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
        }
    return d[n][m];
}

}  // namespace

std::string nearestName(std::string_view given, const std::vector<std::string>& names) {
    if (given.size() > 64) return "";  // a hostile value: nothing is near
    const std::string g = foldedName(given);
    std::string best;
    std::size_t bestDistance = 0;
    for (const std::string& name : names) {
        const std::size_t dist = editDistance(g, foldedName(name));
        if (best.empty() || dist < bestDistance) best = name, bestDistance = dist;
    }
    if (best.empty() || 3 * bestDistance > best.size()) return "";
    return best;
}

std::string didYouMean(std::string_view given, const std::vector<std::string>& names) {
    const std::string near = nearestName(given, names);
    return near.empty() ? "" : " (did you mean '" + near + "'?)";
}

}  // namespace udvr
