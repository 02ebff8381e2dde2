// SPDX-License-Identifier: Apache-2.0
#pragma once
// Stopping a running operation when its caller asks. The plugin installs
// the caller's question for the calling thread (CancelCheck); the stages
// ask it before each kernel they enqueue (stop_if_cancelled), so a cancel
// takes effect at the next kernel boundary: the kernels already queued
// finish, nothing half-enqueued is read, and every buffer is released by
// the unwinding that Cancelled starts.
#include <atomic>
#include <cstddef>
#include <functional>

#include "errors.h"

namespace relief::host {

struct Cancelled : Error {
    Cancelled() : Error("cancelled") {}
};

// While it lives, `requested` is this thread's question (nested checks
// stack: the innermost one is asked).
class CancelCheck {
public:
    explicit CancelCheck(std::function<bool()> requested);
    ~CancelCheck();
    CancelCheck(const CancelCheck&) = delete;
    CancelCheck& operator=(const CancelCheck&) = delete;

private:
    std::function<bool()> requested_;
    const std::function<bool()>* previous_;
};

// Whether this thread's check says stop (false when none is installed).
// Asking it is also the caller's heartbeat (plugin's paced).
bool cancel_requested();

// Whether this thread has a check installed.
bool cancel_check_installed() noexcept;

// Throws Cancelled when this thread's check says so (nothing when none is
// installed).
void stop_if_cancelled();

// stop_if_cancelled() at every `period`-th item of a long host pass (item
// 0, `period`, ...): a pass over a whole map stays within reach of a cancel.
inline void stop_if_cancelled_every(std::size_t item, std::size_t period = 65536)
{
    if (item % period == 0)
        stop_if_cancelled();
}

// Runs `work` on a thread of its own while this thread asks its check every
// 10 ms (so the host still hears its heartbeat): for a library's call or a
// system call that cannot ask by itself (TinyGLTF's serialiser, fsync).
// `stop` turns true once the check says stop; `work` may then end early by
// throwing, or run to its end. Either way this returns only after `work`
// has ended: Cancelled when the check said stop (whatever `work` threw
// then), else what `work` threw. `work` runs outside this thread: it must not use this
// thread's check, callbacks or error state.
void run_asking(const std::function<void(const std::atomic<bool>& stop)>& work);

}  // namespace relief::host
