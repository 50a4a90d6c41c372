#include "udvr/serve/render_gate.h"

#include <chrono>

#include "udvr/render/render.h"
#include "udvr/util/check.h"

namespace udvr::serve {

RenderGate::Channel& RenderGate::channelFor(const std::string& name) {
    auto it = channels_.find(name);
    if (it == channels_.end()) {
        if (channels_.size() >= kMaxChannels) {
            auto victim = channels_.end();
            for (auto c = channels_.begin(); c != channels_.end(); ++c)
                if (c->second.users == 0 &&
                    (victim == channels_.end() || c->second.lastUse < victim->second.lastUse))
                    victim = c;
            if (victim == channels_.end())
                UDVR_FAIL("too many channels with requests under way (at most " << kMaxChannels
                                                                                << ")");
            channels_.erase(victim);
            ++stats_.evicted;
        }
        it = channels_.emplace(name, Channel{}).first;
    }
    it->second.lastUse = ++clock_;
    return it->second;
}

bool RenderGate::run(const std::string& channel, std::optional<std::uint64_t> seq,
                     const std::function<void(const std::atomic<bool>& cancel)>& render,
                     std::shared_ptr<std::atomic<bool>> cancel) {
    const bool own = cancel != nullptr;  // the client's flag: polled while waiting
    if (!cancel) cancel = std::make_shared<std::atomic<bool>>(false);
    std::unique_lock lock(mutex_);
    Channel* c = channel.empty() ? nullptr : &channelFor(channel);  // std::map: stays valid
    if (c) ++c->users;                                              // and is not evicted
    const auto leave = [&] {                                        // under the lock
        if (c) --c->users;
    };
    if (c && seq && *seq < c->maxSeq) {
        ++stats_.superseded;
        leave();
        return false;
    }
    if (c && seq) c->maxSeq = *seq;
    const std::uint64_t ticket = c ? ++c->newest : 0;
    if (c && c->running) c->running->store(true);  // the older render on this channel stops
    turn_.notify_all();                            // and older waiters on it give up
    ++stats_.waiting;
    const auto mayGo = [&] { return !busy_ || (c && c->newest != ticket) || cancel->load(); };
    while (!mayGo()) {
        if (own)
            turn_.wait_for(lock, std::chrono::milliseconds(20));
        else
            turn_.wait(lock);
    }
    --stats_.waiting;
    if ((c && c->newest != ticket) || cancel->load()) {
        ++(c && c->newest != ticket ? stats_.superseded : stats_.abandoned);
        leave();
        return false;
    }
    busy_ = true;
    ++stats_.running;
    if (c) c->running = cancel;
    lock.unlock();

    bool done = false;
    const auto finish = [&] {
        lock.lock();
        busy_ = false;
        --stats_.running;
        if (c && c->running == cancel) c->running.reset();
        if (done)
            ++stats_.completed;
        else if (c && c->newest != ticket)
            ++stats_.cancelled;
        else
            ++stats_.abandoned;
        leave();
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
    Stats s = stats_;
    s.channels = channels_.size();
    return s;
}

}  // namespace udvr::serve
