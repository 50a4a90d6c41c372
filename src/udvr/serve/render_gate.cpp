#include "udvr/serve/render_gate.h"

#include "udvr/render/render.h"
#include "udvr/util/check.h"

namespace udvr::serve {

bool RenderGate::run(const std::string& channel, std::optional<std::uint64_t> seq,
                     const std::function<void(const std::atomic<bool>& cancel)>& render) {
    std::unique_lock lock(mutex_);
    if (!channels_.count(channel) && channels_.size() >= kMaxChannels)
        UDVR_FAIL("too many channels (at most " << kMaxChannels << ")");
    Channel& c = channels_[channel];  // std::map: the reference stays valid
    if (seq && *seq < c.maxSeq) {
        ++stats_.superseded;
        return false;
    }
    if (seq) c.maxSeq = *seq;
    const std::uint64_t ticket = ++c.newest;
    if (c.running) c.running->store(true);  // the older render on this channel stops
    turn_.notify_all();                     // and older waiters on it give up
    ++stats_.waiting;
    turn_.wait(lock, [&] { return !busy_ || c.newest != ticket; });
    --stats_.waiting;
    if (c.newest != ticket) {
        ++stats_.superseded;
        return false;
    }
    busy_ = true;
    ++stats_.running;
    auto cancel = std::make_shared<std::atomic<bool>>(false);
    c.running = cancel;
    lock.unlock();

    bool done = false;
    const auto finish = [&] {
        lock.lock();
        busy_ = false;
        --stats_.running;
        if (c.running == cancel) c.running.reset();
        if (done)
            ++stats_.completed;
        else
            ++stats_.cancelled;
        turn_.notify_all();
    };
    try {
        render(*cancel);
        done = true;
    } catch (const RenderCancelled&) {
        finish();
        return false;
    } catch (...) {
        done = true;  // an error is an answer, not a cancellation
        finish();
        throw;
    }
    finish();
    return true;
}

RenderGate::Stats RenderGate::stats() const {
    std::lock_guard lock(mutex_);
    return stats_;
}

}  // namespace udvr::serve
