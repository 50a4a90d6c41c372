#pragma once
// The HTTP side of `udvr serve` (cpp-httplib): the page's embedded files and the API (api.h).
#include <functional>
#include <string>

#include "udvr/serve/api.h"

namespace udvr::serve {

/// Serve `api` and the embedded page on host:port (port 0: any free port) until the process
/// ends; `ready(port)` is called once the socket listens. Throws UdvrError when it cannot bind.
void runHttpServer(Api& api, const std::string& host, int port,
                   const std::function<void(int port)>& ready);

}  // namespace udvr::serve
