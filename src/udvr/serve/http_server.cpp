#include "udvr/serve/http_server.h"

#include <arpa/inet.h>
#include <httplib.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "udvr/serve/request_guard.h"
#include "udvr/serve/web_assets.h"
#include "udvr/util/check.h"
#include "udvr/util/watcher_thread.h"

namespace udvr::serve {
namespace {

using Clock = std::chrono::steady_clock;

// Requests on one keep-alive connection before it is closed.
constexpr int kMaxRequestsPerConnection = 100;
// How often the watcher looks for clients that went away while their request is handled.
constexpr auto kWatchInterval = std::chrono::milliseconds(50);

Clock::time_point after(double seconds) {
    return Clock::now() +
           std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
}

int millisecondsUntil(Clock::time_point t) {
    const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(t - Clock::now()).count();
    return static_cast<int>(std::clamp<long long>(ms, 0, 1 << 30));
}

// poll() one socket until `events` or the deadline; true when it is ready (or hung up).
bool waitFor(int fd, short events, Clock::time_point deadline) {
    for (;;) {
        pollfd p{fd, events, 0};
        const int r = ::poll(&p, 1, millisecondsUntil(deadline));
        if (r > 0) return true;
        if (r == 0) return false;
        if (errno != EINTR) return true;  // the read or write says what is wrong
    }
}

// One open connection, as the registry and its watcher see it.
struct Connection {
    int fd = -1;
    bool handling = false;  // false: waiting for a request (keep-alive idle or its head)
    std::atomic<bool> evicted{false};
    Clock::time_point since = Clock::now();
    std::shared_ptr<std::atomic<bool>> gone;  // set when the client goes while handling
    bool closeAfter = false;                  // the body was left unread: close after answering
    std::shared_ptr<void> hold;               // the answer's body budget, until it is sent
};

// The open connections: a cap (the oldest waiting connection makes room for a new one), and
// a watcher that marks requests whose client has gone (FIN, reset) so their work is cancelled.
class Registry {
  public:
    explicit Registry(int maxConnections) : max_(maxConnections) {
        watcher_ = std::thread([this] { watch(); });
    }
    ~Registry() { stopWatcher(mutex_, stop_, changed_, watcher_); }
    Registry(const Registry&) = delete;
    Registry& operator=(const Registry&) = delete;

    /// A slot for a new connection: free, or made by closing the connection that has waited
    /// longest for its request; false when every connection is handling one.
    bool reserve() {
        std::lock_guard lock(mutex_);
        if (slots_ < max_) {
            ++slots_;
            return true;
        }
        Connection* oldest = nullptr;
        for (Connection* c : open_)
            if (!c->handling && !c->evicted && (!oldest || c->since < oldest->since)) oldest = c;
        if (!oldest) return false;
        oldest->evicted = true;
        ::shutdown(oldest->fd, SHUT_RDWR);  // its thread sees the end of the stream and leaves
        ++slots_;                           // over the cap until it has left
        return true;
    }
    void release() {
        std::lock_guard lock(mutex_);
        --slots_;
        changed_.notify_all();
    }
    void waitUntilEmpty() {
        std::unique_lock lock(mutex_);
        changed_.wait(lock, [&] { return slots_ == 0; });
    }
    void add(Connection* c) {
        std::lock_guard lock(mutex_);
        open_.push_back(c);
    }
    void remove(Connection* c) {
        std::lock_guard lock(mutex_);
        open_.erase(std::find(open_.begin(), open_.end(), c));
    }
    void setHandling(Connection* c, bool handling) {
        std::lock_guard lock(mutex_);
        c->handling = handling;
        c->since = Clock::now();
        if (handling) c->gone = std::make_shared<std::atomic<bool>>(false);
    }
    int maxConnections() const { return max_; }

  private:
    void watch() {
        std::unique_lock lock(mutex_);
        while (!stop_) {
            changed_.wait_for(lock, kWatchInterval);
            std::vector<pollfd> fds;
            std::vector<Connection*> who;
            for (Connection* c : open_)
                if (c->handling && !c->gone->load()) {
                    fds.push_back(pollfd{c->fd, POLLRDHUP, 0});
                    who.push_back(c);
                }
            if (fds.empty() || ::poll(fds.data(), fds.size(), 0) <= 0) continue;
            for (std::size_t k = 0; k < fds.size(); ++k)
                if (fds[k].revents & (POLLRDHUP | POLLHUP | POLLERR)) who[k]->gone->store(true);
        }
    }

    const int max_;
    std::mutex mutex_;
    std::condition_variable changed_;
    std::vector<Connection*> open_;
    int slots_ = 0;
    bool stop_ = false;
    std::thread watcher_;
};

// A JSON error as the raw bytes of a whole response (for answers outside httplib's requests).
std::string rawError(int status, const char* reason, const std::string& message) {
    const std::string body = R"({"error":")" + message + "\"}";
    return "HTTP/1.1 " + std::to_string(status) + " " + reason +
           "\r\nContent-Type: application/json\r\nCache-Control: no-store\r\nConnection: "
           "close\r\nContent-Length: " +
           std::to_string(body.size()) + "\r\n\r\n" + body;
}

// A connection's socket as httplib reads and writes it: buffered, each request's head and body
// within byte budgets and one deadline, each response within a write deadline.
class BoundedStream final : public httplib::Stream {
  public:
    enum class Failure { None, TooLarge, Timeout };

    BoundedStream(int fd, const HttpOptions& o) : fd_(fd), o_(o) {}

    bool is_readable() const override { return begin_ < end_ || waitFor(fd_, POLLIN, deadline_); }
    bool is_writable() const override { return waitFor(fd_, POLLOUT, writeDeadline()); }

    ssize_t read(char* ptr, size_t size) override {
        if (budget_ == 0) {
            failure_ = Failure::TooLarge;
            return -1;
        }
        if (begin_ == end_) {
            if (!waitFor(fd_, POLLIN, deadline_)) {
                failure_ = Failure::Timeout;
                return -1;
            }
            ssize_t n;
            do n = ::recv(fd_, buffer_, sizeof buffer_, MSG_DONTWAIT);
            while (n < 0 && errno == EINTR);
            if (n <= 0) return n < 0 && errno == EAGAIN ? read(ptr, size) : (n < 0 ? -1 : 0);
            begin_ = 0;
            end_ = static_cast<std::size_t>(n);
        }
        const std::size_t n = std::min({size, end_ - begin_, budget_});
        std::memcpy(ptr, buffer_ + begin_, n);
        begin_ += n;
        budget_ -= n;
        return static_cast<ssize_t>(n);
    }

    ssize_t write(const char* ptr, size_t size) override {
        if (failure_ != Failure::None) {  // httplib's answer to a failed read: ours instead
            answerFailure();
            return static_cast<ssize_t>(size);
        }
        return send(ptr, size);
    }

    /// After a read failed (the head over its budget, the request past its deadline): 431 or 408
    /// with a message, once.
    void answerFailure() {
        if (failure_ == Failure::None || answered_) return;
        answered_ = true;
        const std::string text =
            failure_ == Failure::TooLarge && body_
                ? rawError(413, "Payload Too Large",
                           "the body (with its chunks' framing) is over the limit of " +
                               std::to_string(o_.maxBodyBytes) + " bytes (udvr serve --max-body)")
            : failure_ == Failure::TooLarge
                ? rawError(431, "Request Header Fields Too Large",
                           "the request's head is over " + std::to_string(o_.maxHeaderBytes) +
                               " bytes (udvr serve --max-header)")
                : rawError(408, "Request Timeout",
                           "the request did not arrive within " + seconds(o_.readTimeout) +
                               " s (udvr serve --read-timeout)");
        (void)send(text.data(), text.size());
    }

  private:
    static std::string seconds(double s) {
        char text[32];
        std::snprintf(text, sizeof text, "%g", s);
        return text;
    }

    ssize_t send(const char* ptr, size_t size) {
        const Clock::time_point deadline = writeDeadline();
        std::size_t done = 0;
        while (done < size) {
            const ssize_t n = ::send(fd_, ptr + done, size - done, MSG_NOSIGNAL | MSG_DONTWAIT);
            if (n > 0) {
                done += static_cast<std::size_t>(n);
                continue;
            }
            if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) return -1;
            if (!waitFor(fd_, POLLOUT, deadline)) {
                failure_ = Failure::Timeout;
                return -1;
            }
        }
        written_ += size;
        return static_cast<ssize_t>(size);
    }

  public:
    void get_remote_ip_and_port(std::string& ip, int& port) const override {
        address(::getpeername, ip, port);
    }
    void get_local_ip_and_port(std::string& ip, int& port) const override {
        address(::getsockname, ip, port);
    }
    socket_t socket() const override { return fd_; }

    /// Whether a request starts within `seconds` (buffered bytes count).
    bool waitForRequest(double seconds) const {
        return begin_ < end_ || waitFor(fd_, POLLIN, after(seconds));
    }
    /// A new request: its head may take o.maxHeaderBytes and, with its body, must have arrived
    /// by `deadline`.
    void startHead(Clock::time_point deadline) {
        budget_ = o_.maxHeaderBytes;
        deadline_ = deadline;
        writeDeadline_.reset();
        written_ = 0;
        failure_ = Failure::None;
        answered_ = false;
        body_ = false;
    }
    /// The head has been read: the body may take `bytes` (within the same deadline).
    void startBody(std::size_t bytes) {
        budget_ = bytes;
        body_ = true;
    }

    Failure failure() const { return failure_; }
    std::size_t written() const { return written_; }

  private:
    Clock::time_point writeDeadline() const {
        if (!writeDeadline_) writeDeadline_ = after(o_.writeTimeout);
        return *writeDeadline_;
    }
    template <class Get>
    void address(Get get, std::string& ip, int& port) const {
        sockaddr_storage a{};
        socklen_t len = sizeof a;
        ip.clear();
        port = -1;
        if (get(fd_, reinterpret_cast<sockaddr*>(&a), &len) != 0) return;
        char text[INET6_ADDRSTRLEN] = {};
        if (a.ss_family == AF_INET) {
            const auto* v4 = reinterpret_cast<const sockaddr_in*>(&a);
            ::inet_ntop(AF_INET, &v4->sin_addr, text, sizeof text);
            port = ntohs(v4->sin_port);
        } else if (a.ss_family == AF_INET6) {
            const auto* v6 = reinterpret_cast<const sockaddr_in6*>(&a);
            ::inet_ntop(AF_INET6, &v6->sin6_addr, text, sizeof text);
            port = ntohs(v6->sin6_port);
        }
        ip = text;
    }

    const int fd_;
    const HttpOptions& o_;
    char buffer_[16384];
    std::size_t begin_ = 0, end_ = 0;
    std::size_t budget_ = 0;
    Clock::time_point deadline_ = Clock::now();
    mutable std::optional<Clock::time_point> writeDeadline_;
    std::size_t written_ = 0;
    mutable Failure failure_ = Failure::None;
    bool answered_ = false;
    bool body_ = false;  // reading the body (else the head)
};

// The connection the current thread serves (each connection has its own thread).
thread_local Connection* tConnection = nullptr;
// Set while the accept thread runs a connection it has no room for: answer 503 and close.
thread_local bool tNoRoom = false;

// Close after a response: FIN first, then read what the client still sends for a moment (at most
// 256 KiB, 200 ms), so a refused body's client sees the answer rather than a reset.
void closeGently(int fd) {
    ::shutdown(fd, SHUT_WR);
    const Clock::time_point until = Clock::now() + std::chrono::milliseconds(200);
    char sink[16384];
    for (std::size_t total = 0; total < (256u << 10) && waitFor(fd, POLLIN, until);) {
        const ssize_t n = ::recv(fd, sink, sizeof sink, MSG_DONTWAIT);
        if (n <= 0 && !(n < 0 && (errno == EINTR || errno == EAGAIN))) break;
        if (n > 0) total += static_cast<std::size_t>(n);
    }
    ::close(fd);
}

// Each connection in its own thread, up to the registry's cap: a slow client holds only its own
// thread (for at most the read timeout), never one that another request needs.
class ConnectionThreads final : public httplib::TaskQueue {
  public:
    explicit ConnectionThreads(Registry& registry) : registry_(registry) {}
    void enqueue(std::function<void()> fn) override {
        if (registry_.reserve()) {
            try {
                std::thread([this, fn = std::move(fn)] {
                    fn();
                    registry_.release();
                }).detach();
                return;
            } catch (const std::system_error&) {
                registry_.release();
            }
        }
        tNoRoom = true;  // runs here and answers 503 without reading
        fn();
        tNoRoom = false;
    }
    void shutdown() override { registry_.waitUntilEmpty(); }

  private:
    Registry& registry_;
};

class BoundedServer final : public httplib::Server {
  public:
    BoundedServer(Registry& registry, const HttpOptions& o) : registry_(registry), o_(o) {}

  private:
    bool process_and_close_socket(socket_t sock) override {
        if (tNoRoom) {
            const std::string answer =
                rawError(503, "Service Unavailable",
                         "too many connections (udvr serve --max-connections " +
                             std::to_string(registry_.maxConnections()) + ")");
            (void)::send(sock, answer.data(), answer.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
            ::shutdown(sock, SHUT_WR);
            ::close(sock);  // at once: this is the thread that accepts connections
            return true;
        }
        Connection connection;
        connection.fd = sock;
        registry_.add(&connection);
        tConnection = &connection;
        BoundedStream stream(sock, o_);
        for (int n = 0; n < kMaxRequestsPerConnection && !connection.evicted; ++n) {
            registry_.setHandling(&connection, false);
            // The first request must have arrived within the read timeout of the connection's
            // start; each later one within it of its first byte.
            const Clock::time_point byThen = after(o_.readTimeout);
            if (!stream.waitForRequest(n == 0 ? o_.readTimeout : o_.keepAliveTimeout)) break;
            stream.startHead(n == 0 ? byThen : after(o_.readTimeout));
            connection.closeAfter = false;
            bool closed = false;
            const bool ok = process_request(
                stream, n + 1 == kMaxRequestsPerConnection, closed, [&](httplib::Request& req) {
                    registry_.setHandling(&connection, true);
                    req.ranges.clear();  // byte ranges are not served: one body, as it is
                    stream.startBody(bodyBudget(req));
                });
            connection.hold.reset();                            // the answer has been sent
            if (stream.written() == 0) stream.answerFailure();  // httplib wrote nothing
            if (!ok || closed || connection.closeAfter ||
                stream.failure() != BoundedStream::Failure::None)
                break;
        }
        registry_.remove(&connection);
        tConnection = nullptr;
        closeGently(sock);
        return true;
    }

    // The bytes the body may take from the stream: its Content-Length (refused above the limit
    // before reading), or for chunked bodies the limit with room for the chunks' framing.
    std::size_t bodyBudget(const httplib::Request& req) const {
        if (req.has_header("Transfer-Encoding")) return 8 * o_.maxBodyBytes + (64u << 10);
        const std::string length = req.get_header_value("Content-Length");
        char* end = nullptr;
        const unsigned long long n = std::strtoull(length.c_str(), &end, 10);
        return !length.empty() && *end == '\0' && n <= o_.maxBodyBytes ? n : 0;
    }

    Registry& registry_;
    const HttpOptions& o_;
};

void answer(ApiResponse&& a, httplib::Response& res) {
    res.status = a.status;
    for (const auto& [k, v] : a.headers) res.set_header(k, v);
    res.set_header("Cache-Control", "no-store");
    res.set_header("Content-Type", a.type);
    res.body = std::move(a.body);  // no copy of a 16 MiB image
    if (tConnection) tConnection->hold = std::move(a.hold);
}

void answerError(int status, const std::string& message, httplib::Response& res) {
    answer(ApiResponse{status,
                       "application/json",
                       nlohmann::json{{"error", message}}.dump(
                           -1, ' ', false, nlohmann::json::error_handler_t::replace),
                       {},
                       nullptr},
           res);
}

ApiRequest toApiRequest(const httplib::Request& req) {
    ApiRequest r;
    r.method = req.method;
    r.path = req.path;
    for (const auto& [k, v] : req.params) r.params.emplace_back(k, v);
    // httplib keeps a multimap sorted by key; the API needs only presence and repeats.
    if (tConnection) r.cancel = tConnection->gone;
    return r;
}

}  // namespace

void runHttpServer(Api& api, const HttpOptions& o, const std::function<void(int port)>& ready) {
    // glibc raises its mmap threshold after each large free (up to 32 MiB), after which frames,
    // rasters and tables come from per-thread arenas that keep their pages: test_serve_soak saw
    // 430-540 MiB resident for ~100 MiB live. A fixed threshold turns that off, so blocks of
    // kReturnedBlockBytes and more go back to the system when freed (soak: 111 MiB).
#if defined(__GLIBC__)
    mallopt(M_MMAP_THRESHOLD, static_cast<int>(kReturnedBlockBytes));
#endif
    Registry registry(o.maxConnections);
    BoundedServer server(registry, o);
    server.new_task_queue = [&registry] { return new ConnectionThreads(registry); };
    server.set_keep_alive_timeout(static_cast<time_t>(std::ceil(o.keepAliveTimeout)));
    server.set_keep_alive_max_count(kMaxRequestsPerConnection);  // as the loop above keeps them
    server.set_payload_max_length(o.maxBodyBytes);
    // SO_REUSEADDR (a restart may take the port at once) but not httplib's SO_REUSEPORT, with
    // which a second server on the same port would start and share the requests.
    server.set_socket_options([](socket_t sock) {
        int yes = 1;
        setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    });
    // Before any body is read: who may ask (Host, Origin), and what body may come.
    server.set_pre_routing_handler([&o](const httplib::Request& req, httplib::Response& res) {
        const auto refuse = [&](int status, const std::string& message) {
            answerError(status, message, res);
            if (tConnection) tConnection->closeAfter = true;
            return httplib::Server::HandlerResponse::Handled;
        };
        if (const auto why =
                refusedOrigin(req.get_header_value("Host"), req.get_header_value("Origin"),
                              req.get_header_value("Sec-Fetch-Site"), o.allowHosts))
            return refuse(403, *why);
        if (req.method != "GET" && req.method != "HEAD" && req.method != "POST")
            return refuse(405, "method " + req.method.substr(0, 16) + " not allowed");
        const BodyHeaders body{req.method, req.get_header_value("Content-Length"),
                               req.get_header_value("Transfer-Encoding"),
                               req.get_header_value("Content-Encoding"),
                               req.get_header_value("Content-Type")};
        if (const auto why = refusedBody(body, o.maxBodyBytes))
            return refuse(why->first, why->second);
        return httplib::Server::HandlerResponse::Unhandled;
    });
    server.Get(R"(/api/.*)", [&api](const httplib::Request& req, httplib::Response& res) {
        answer(api.handle(toApiRequest(req)), res);
    });
    // POST bodies through a reader, so that a chunked body stops at the limit too.
    server.Post(R"(/api/.*)", [&api, &o](const httplib::Request& req, httplib::Response& res,
                                         const httplib::ContentReader& reader) {
        ApiRequest r = toApiRequest(req);
        bool over = false;
        const bool read = reader([&](const char* data, std::size_t n) {
            if (r.body.size() + n > o.maxBodyBytes) {
                over = true;
                return false;
            }
            r.body.append(data, n);
            return true;
        });
        if (!read || over) {
            if (tConnection) tConnection->closeAfter = true;
            return answerError(over ? 413 : 400,
                               over ? "the body is over " + std::to_string(o.maxBodyBytes) +
                                          " bytes (udvr serve --max-body)"
                                    : std::string("the body did not arrive whole"),
                               res);
        }
        answer(api.handle(r), res);
    });
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
        answerError(404, "not found", res);
    });
    server.set_exception_handler(
        [](const httplib::Request&, httplib::Response& res, std::exception_ptr) {
            answerError(500, "internal error", res);
        });
    int bound = -1;
    if (o.port == 0)
        bound = server.bind_to_any_port(o.host);
    else if (server.bind_to_port(o.host, o.port))
        bound = o.port;
    if (bound < 0)
        UDVR_FAIL("cannot listen on " << o.host << ":" << o.port
                                      << " (in use, or not an address of this machine: --port "
                                         "0 picks a free port)");
    ready(bound);
    server.listen_after_bind();
}

}  // namespace udvr::serve
