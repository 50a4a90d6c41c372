#pragma once
// The HTTP side of `udvr serve` (cpp-httplib): the page's embedded files and the API (api.h).
// Every connection is read through a bounded stream: the request's head and body have byte
// limits and one deadline, a response one write deadline, and connections are capped (the
// oldest one still waiting for its request makes room for a new one), so neither slow nor
// flooding clients hold memory or the threads that answer others (docs/serve.md, Security).
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "udvr/serve/api.h"

namespace udvr::serve {

struct HttpOptions {
    std::string host = "127.0.0.1";
    int port = 8080;
    /// Host names taken besides loopback ones (a reverse proxy's); "*" takes any Host.
    std::vector<std::string> allowHosts;
    double readTimeout = 10.0;               // s: a request's head and body must arrive within it
    double writeTimeout = 60.0;              // s: a response must be taken within it
    double keepAliveTimeout = 2.0;           // s: an idle keep-alive connection is closed after it
    int maxConnections = 64;                 // open at once (each has a thread)
    std::size_t maxHeaderBytes = 64 * 1024;  // request line and headers
    std::size_t maxBodyBytes = kMaxBodyBytes;
};

/// Serve `api` and the embedded page until the process ends; `ready(port)` is called once the
/// socket listens (port 0: any free port). Throws UdvrError when it cannot bind.
void runHttpServer(Api& api, const HttpOptions& options,
                   const std::function<void(int port)>& ready);

}  // namespace udvr::serve
