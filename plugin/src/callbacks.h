// SPDX-License-Identifier: Apache-2.0
#pragma once
// A host's callbacks (Execution's on_message, on_progress, cancel) run on
// the thread of the operation that calls them, which holds the device's
// queue meanwhile. A callback that calls relief again on that thread would
// wait for itself; so every callback runs marked (InCallback), and an
// operation started inside one is refused at once (reentry_problem), in
// every front end: the C ABI's RELIEF_INVALID, a failed C++ call, a Python
// exception. Another thread's call waits its turn as before.
#include <chrono>
#include <functional>
#include <string>

#include "relief/options.h"

namespace relief::detail {

// While it lives, this thread is inside a host's callback.
class InCallback {
public:
    InCallback() noexcept;
    ~InCallback();
    InCallback(const InCallback&) = delete;
    InCallback& operator=(const InCallback&) = delete;
};

// Whether this thread is inside a host's callback now.
bool in_callback() noexcept;

// "" outside callbacks; inside one, why an operation is refused.
std::string reentry_problem();

// `f` run marked, for the host stages that take the callbacks as they are
// (null stays null).
std::function<void(double)> marked(std::function<void(double)> f);
std::function<bool()> marked(std::function<bool()> f);
std::function<void(Severity, const std::string&)> marked(std::function<void(Severity, const std::string&)> f);

// `exec` as the table runs it (every front end: the command line, the C
// ABI, Python), with two rules for its progress:
// - A heartbeat. The stages ask cancel before each kernel they queue
//   (host/device/cancel.h); when they do and `interval` has passed since
//   the host last heard progress, on_progress hears the last fraction
//   again. A host whose only way to cancel is its progress callback (the C
//   ABI, Python's callable) is asked at least that often while kernels
//   run, also in a stage that has no finer measure of its own.
// - One final call. Only the table's last call (1, once the result is
//   complete) reports 1: a stage's own 1 is not passed on, so a cancel
//   answered to 1 always comes after the work, and the operation returns
//   its result.
inline constexpr std::chrono::milliseconds kHeartbeat{50};
Execution paced(const Execution& exec, std::chrono::steady_clock::duration interval = kHeartbeat);

}  // namespace relief::detail
