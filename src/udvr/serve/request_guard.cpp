#include "udvr/serve/request_guard.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdlib>

namespace udvr::serve {
namespace {

std::string lower(std::string s) {
    for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

bool allDigits(const std::string& s) {
    return !s.empty() && s.size() <= 5 &&
           std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c); });
}

bool endsWith(const std::string& s, const std::string& tail) {
    return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

}  // namespace

std::string hostNameOf(const std::string& hostHeader) {
    const std::string h = lower(hostHeader);
    if (h.empty() || h.size() > 255) return {};
    std::string name, port;
    if (h[0] == '[') {
        const auto close = h.find(']');
        if (close == std::string::npos) return {};
        name = h.substr(1, close - 1);
        const std::string rest = h.substr(close + 1);
        if (!rest.empty()) {
            if (rest[0] != ':') return {};
            port = rest.substr(1);
            if (!allDigits(port)) return {};
        }
        for (char c : name)
            if (!(std::isxdigit(static_cast<unsigned char>(c)) || c == ':' || c == '.')) return {};
        return name.empty() ? std::string() : name;
    }
    const auto colon = h.find(':');
    name = h.substr(0, colon);
    if (colon != std::string::npos && !allDigits(h.substr(colon + 1))) return {};
    for (char c : name)
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '.' || c == '_'))
            return {};
    return name;
}

bool isLoopbackName(const std::string& name) {
    if (name == "localhost" || endsWith(name, ".localhost") || name == "::1" ||
        name == "0:0:0:0:0:0:0:1")
        return true;
    // 127.a.b.c, each part 0-255 in decimal.
    int parts = 0;
    std::size_t start = 0;
    while (start <= name.size()) {
        const auto dot = name.find('.', start);
        const std::string part =
            name.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
        if (part.empty() || part.size() > 3 ||
            !std::all_of(part.begin(), part.end(), [](unsigned char c) { return std::isdigit(c); }))
            return false;
        if (std::stoi(part) > 255 || (parts == 0 && part != "127")) return false;
        ++parts;
        if (dot == std::string::npos) break;
        start = dot + 1;
    }
    return parts == 4;
}

std::optional<std::string> refusedOrigin(const std::string& host, const std::string& origin,
                                         const std::string& secFetchSite,
                                         const std::vector<std::string>& allowHosts) {
    const bool any = std::find(allowHosts.begin(), allowHosts.end(), "*") != allowHosts.end();
    const std::string name = hostNameOf(host);
    if (!any) {
        if (name.empty()) return std::string("the Host header is missing or malformed");
        if (!isLoopbackName(name) &&
            std::find(allowHosts.begin(), allowHosts.end(), name) == allowHosts.end())
            return "Host '" + host.substr(0, 64) +
                   "' is not a loopback name or address (start udvr serve with --allow-host " +
                   name.substr(0, 64) + " to take it)";
    }
    if (!origin.empty()) {
        // A browser's request from a page: that page must be the server's own.
        const std::string o = lower(origin);
        std::string authority;
        if (o.rfind("http://", 0) == 0) authority = o.substr(7);
        if (o.rfind("https://", 0) == 0) authority = o.substr(8);
        if (!authority.empty() && authority.back() == '/') authority.pop_back();
        if (authority.empty() || authority != lower(host))
            return "Origin '" + origin.substr(0, 64) + "' is not this server's own";
    }
    if (!secFetchSite.empty() && secFetchSite != "same-origin" && secFetchSite != "none")
        return "a request from another site (Sec-Fetch-Site: " + secFetchSite.substr(0, 32) + ")";
    return std::nullopt;
}

std::optional<std::pair<int, std::string>> refusedBody(const BodyHeaders& h, std::size_t maxBody) {
    const bool post = h.method == "POST";
    if (!h.contentEncoding.empty() && lower(h.contentEncoding) != "identity")
        return std::pair{415, "Content-Encoding '" + h.contentEncoding.substr(0, 32) +
                                  "' is not taken: send the body as it is"};
    if (lower(h.contentType).rfind("multipart/", 0) == 0)
        return std::pair{415, std::string("multipart bodies are not taken: send the JSON as "
                                          "the body (Content-Type: application/json)")};
    if (!h.transferEncoding.empty()) {
        if (!post) return std::pair{400, std::string("a " + h.method + " request has no body")};
        if (lower(h.transferEncoding) != "chunked")
            return std::pair{501, "Transfer-Encoding '" + h.transferEncoding.substr(0, 32) +
                                      "' is not taken (chunked or a Content-Length)"};
        if (!h.contentLength.empty())
            return std::pair{400, std::string("both Content-Length and Transfer-Encoding")};
        return std::nullopt;  // chunked: read up to maxBody bytes, then 413
    }
    if (h.contentLength.empty())
        return post ? std::optional{std::pair{411, std::string("a POST needs a Content-Length "
                                                               "(or chunked transfer encoding)")}}
                    : std::nullopt;
    errno = 0;
    char* end = nullptr;
    const unsigned long long length = std::strtoull(h.contentLength.c_str(), &end, 10);
    if (!std::isdigit(static_cast<unsigned char>(h.contentLength[0])) || *end != '\0' ||
        errno == ERANGE)
        return std::pair{400,
                         "Content-Length '" + h.contentLength.substr(0, 32) + "' is not a number"};
    if (!post && length > 0)
        return std::pair{400, std::string("a " + h.method + " request has no body")};
    if (length > maxBody)
        return std::pair{413, "the body is " + std::to_string(length) +
                                  " bytes, over the limit of " + std::to_string(maxBody) +
                                  " (udvr serve --max-body)"};
    return std::nullopt;
}

}  // namespace udvr::serve
