#pragma once
// Which requests `udvr serve` takes before any work (docs/serve.md, Security): the Host must be a
// loopback name or address (or one --allow-host names), a browser's Origin must be the server's
// own and its Sec-Fetch-Site same-origin, and a body must come with a bounded length in a plain
// encoding. Free of any HTTP library, so tests call it directly.
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace udvr::serve {

/// The host part of a Host header value ("name", "name:port", "[v6]", "[v6]:port"), lower case;
/// empty when it is not of that form.
std::string hostNameOf(const std::string& hostHeader);

/// localhost, *.localhost, 127.0.0.0/8 in dotted decimal, ::1 (as hostNameOf gives them).
bool isLoopbackName(const std::string& name);

/// Why a request with these headers is refused (403), or nothing. `allowHosts`: names (as
/// hostNameOf gives them) taken besides loopback ones; "*" takes any Host. Empty strings stand
/// for absent headers.
std::optional<std::string> refusedOrigin(const std::string& host, const std::string& origin,
                                         const std::string& secFetchSite,
                                         const std::vector<std::string>& allowHosts);

/// A request's body as its headers announce it.
struct BodyHeaders {
    std::string method, contentLength, transferEncoding, contentEncoding, contentType;
};

/// Why a request's body is refused before a byte of it is read: the status (411, 413, 415, 400,
/// 501) and a message; nothing when it may be read (at most maxBody bytes of it).
std::optional<std::pair<int, std::string>> refusedBody(const BodyHeaders& h, std::size_t maxBody);

}  // namespace udvr::serve
