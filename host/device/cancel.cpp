// SPDX-License-Identifier: Apache-2.0
#include "device/cancel.h"

#include <chrono>
#include <future>
#include <system_error>
#include <utility>

namespace relief::host {

namespace {
thread_local const std::function<bool()>* current = nullptr;
}

CancelCheck::CancelCheck(std::function<bool()> requested)
    : requested_(std::move(requested)), previous_(current)
{
    if (requested_)
        current = &requested_;
}

CancelCheck::~CancelCheck()
{
    current = previous_;
}

bool cancel_requested()
{
    return current && (*current)();
}

bool cancel_check_installed() noexcept
{
    return current != nullptr;
}

void stop_if_cancelled()
{
    if (cancel_requested())
        throw Cancelled();
}

void run_asking(const std::function<void(const std::atomic<bool>& stop)>& work)
{
    std::atomic<bool> stop{false};
    std::future<void> done;
    try {
        done = std::async(std::launch::async, [&] { work(stop); });
    } catch (const std::system_error&) {  // (no thread to be had: the call runs here, unasked)
        work(stop);
        return;
    }
    while (done.wait_for(std::chrono::milliseconds(10)) != std::future_status::ready)
        if (!stop.load() && cancel_requested())
            stop.store(true);
    try {
        done.get();
    } catch (...) {
        if (stop.load())
            throw Cancelled();  // (how it ended early: what was asked of it)
        throw;
    }
    if (stop.load())
        throw Cancelled();
}

}  // namespace relief::host
