#pragma once
// Who works next in `udvr serve`: one heavy job at a time (a frame uses every core; probes,
// histograms and TF2 rasters take their turn too), and on each channel (a view of the page: the
// main image, a quartile, the truth…) only the newest request counts. A newer request cancels
// the older one that is rendering and supersedes those still waiting, so dragging the mouse never
// builds a queue; a request whose client has gone is cancelled too (its own cancel flag).
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
        std::uint64_t abandoned = 0;   // waiting or running when its client went away
        std::uint64_t evicted = 0;     // idle channels dropped to make room for a new one
        int running = 0, waiting = 0;
        std::size_t channels = 0;
    };

    /// At most this many channels at once (names come from requests): a new one evicts the
    /// least recently used idle channel.
    static constexpr std::size_t kMaxChannels = 64;

    /// Run render(cancel) when it is this request's turn. `channel` empty: the request only
    /// waits for its turn. `seq`, when given, orders the requests of a channel as the client sent
    /// them (a request whose seq is below the newest seen is superseded at once); without it,
    /// arrival order. `cancel`, when given, is the request's own flag (set when its client goes):
    /// a waiting request gives up, a running one sees it as its cancel flag. Returns false when
    /// the request was superseded or cancelled (render saw `cancel` turn true and threw
    /// RenderCancelled), true when render returned. Other exceptions pass through. Throws
    /// UdvrError when kMaxChannels channels all have requests under way.
    bool run(const std::string& channel, std::optional<std::uint64_t> seq,
             const std::function<void(const std::atomic<bool>& cancel)>& render,
             std::shared_ptr<std::atomic<bool>> cancel = nullptr);

    Stats stats() const;

  private:
    struct Channel {
        std::uint64_t newest = 0;                    // ticket of the newest request
        std::uint64_t maxSeq = 0;                    // largest client seq seen
        std::shared_ptr<std::atomic<bool>> running;  // the cancel flag of its running render
        int users = 0;                               // requests under way on it
        std::uint64_t lastUse = 0;
    };
    Channel& channelFor(const std::string& name);  // under mutex_

    mutable std::mutex mutex_;
    std::condition_variable turn_;
    bool busy_ = false;
    std::map<std::string, Channel> channels_;
    std::uint64_t clock_ = 0;
    Stats stats_;
};

}  // namespace udvr::serve
