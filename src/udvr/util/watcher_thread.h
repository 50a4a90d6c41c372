#pragma once
// The shutdown of a watcher thread: a thread that loops beside its owner (checking a deadline,
// polling connections), waiting on a condition variable between rounds, until its owner sets a
// stop flag under the mutex that guards the flag.
#include <condition_variable>
#include <mutex>
#include <thread>

namespace udvr {

/// Stops a watcher thread and waits for it: sets `stop` under `mutex`, wakes `wake` (so the
/// thread need not sleep out its round) and joins `thread`. For owners' destructors.
inline void stopWatcher(std::mutex& mutex, bool& stop, std::condition_variable& wake,
                        std::thread& thread) {
    {
        std::lock_guard lock(mutex);
        stop = true;
    }
    wake.notify_all();
    thread.join();
}

}  // namespace udvr
