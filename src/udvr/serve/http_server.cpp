#include "udvr/serve/http_server.h"

#include <httplib.h>

#include <algorithm>
#include <thread>

#include "udvr/serve/web_assets.h"
#include "udvr/util/check.h"

namespace udvr::serve {
namespace {

// Threads that answer requests: renders take turns in the RenderGate, so most of them wait
// or answer cheap requests; enough that a browser's keep-alive connections never starve a new
// request.
constexpr int kRequestThreads = 24;

void answer(const ApiResponse& a, httplib::Response& res) {
    res.status = a.status;
    for (const auto& [k, v] : a.headers) res.set_header(k, v);
    res.set_header("Cache-Control", "no-store");
    res.set_content(a.body, a.type);
}

ApiRequest toApiRequest(const httplib::Request& req) {
    ApiRequest r;
    r.method = req.method;
    r.path = req.path;
    for (const auto& [k, v] : req.params) r.params.emplace_back(k, v);
    // httplib keeps a multimap sorted by key; the API needs only presence and repeats.
    r.body = req.body;
    return r;
}

}  // namespace

void runHttpServer(Api& api, const std::string& host, int port,
                   const std::function<void(int port)>& ready) {
    httplib::Server server;
    server.new_task_queue = [] { return new httplib::ThreadPool(kRequestThreads); };
    server.set_keep_alive_timeout(2);
    server.set_payload_max_length(kMaxBodyBytes);
    // SO_REUSEADDR (a restart may take the port at once) but not httplib's SO_REUSEPORT, with
    // which a second server on the same port would start and share the requests.
    server.set_socket_options([](socket_t sock) {
        int yes = 1;
        setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    });
    const auto apiHandler = [&api](const httplib::Request& req, httplib::Response& res) {
        answer(api.handle(toApiRequest(req)), res);
    };
    server.Get(R"(/api/.*)", apiHandler);
    server.Post(R"(/api/.*)", apiHandler);
    // The page: an exact match in the table of embedded files; nothing else is served.
    server.Get(R"(/.*)", [](const httplib::Request& req, httplib::Response& res) {
        const std::string path = req.path == "/" ? "/index.html" : req.path;
        for (const WebAsset& a : webAssets())
            if (a.path == path) {
                res.set_content(reinterpret_cast<const char*>(a.data.data()), a.data.size(),
                                std::string(a.mime));
                res.set_header("Cache-Control", "no-cache");
                return;
            }
        answer(ApiResponse{404, "application/json", R"({"error":"not found"})", {}}, res);
    });
    server.set_exception_handler(
        [](const httplib::Request&, httplib::Response& res, std::exception_ptr) {
            answer(ApiResponse{500, "application/json", R"({"error":"internal error"})", {}}, res);
        });
    int bound = -1;
    if (port == 0)
        bound = server.bind_to_any_port(host);
    else if (server.bind_to_port(host, port))
        bound = port;
    if (bound < 0)
        UDVR_FAIL("cannot listen on " << host << ":" << port
                                      << " (in use, or not an address of this machine: --port "
                                         "0 picks a free port)");
    ready(bound);
    server.listen_after_bind();
}

}  // namespace udvr::serve
