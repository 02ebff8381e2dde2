// SPDX-License-Identifier: Apache-2.0
#pragma once
// Stopping a running operation when its caller asks. The plugin installs
// the caller's question for the calling thread (CancelCheck); the stages
// ask it before each kernel they enqueue (stop_if_cancelled), so a cancel
// takes effect at the next kernel boundary: the kernels already queued
// finish, nothing half-enqueued is read, and every buffer is released by
// the unwinding that Cancelled starts.
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

}  // namespace relief::host
