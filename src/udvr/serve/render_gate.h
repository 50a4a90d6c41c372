#pragma once
// Who renders next in `udvr serve`: one frame at a time (a frame uses every core), and on each
// channel (a view of the page: the main image, a quartile, the truth…) only the newest request
// counts. A newer request cancels the older one that is rendering and supersedes those still
// waiting, so dragging the mouse never builds a queue.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace udvr::serve {

class RenderGate {
  public:
    /// Counts since the start, and what is under way now.
    struct Stats {
        std::uint64_t completed = 0;   // renders that finished (an image or an error)
        std::uint64_t cancelled = 0;   // stopped mid-frame by a newer request
        std::uint64_t superseded = 0;  // never started: a newer request came first
        int running = 0, waiting = 0;
    };

    /// At most this many channels (names come from requests).
    static constexpr std::size_t kMaxChannels = 64;

    /// Run render(cancel) when it is this request's turn. `seq`, when given, orders the requests
    /// of a channel as the client sent them (a request whose seq is below the newest seen is
    /// superseded at once); without it, arrival order. Returns false when the request was
    /// superseded or cancelled (render saw `cancel` turn true and threw RenderCancelled), true
    /// when render returned. Other exceptions pass through. Throws UdvrError for a channel over
    /// kMaxChannels.
    bool run(const std::string& channel, std::optional<std::uint64_t> seq,
             const std::function<void(const std::atomic<bool>& cancel)>& render);

    Stats stats() const;

  private:
    struct Channel {
        std::uint64_t newest = 0;                    // ticket of the newest request
        std::uint64_t maxSeq = 0;                    // largest client seq seen
        std::shared_ptr<std::atomic<bool>> running;  // the cancel flag of its running render
    };
    mutable std::mutex mutex_;
    std::condition_variable turn_;
    bool busy_ = false;
    std::map<std::string, Channel> channels_;
    Stats stats_;
};

}  // namespace udvr::serve
