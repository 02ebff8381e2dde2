// SPDX-License-Identifier: Apache-2.0
#include "callbacks.h"

#include <memory>
#include <utility>

namespace relief::detail {

namespace {

thread_local int callback_depth = 0;

}  // namespace

InCallback::InCallback() noexcept
{
    ++callback_depth;
}

InCallback::~InCallback()
{
    --callback_depth;
}

bool in_callback() noexcept
{
    return callback_depth > 0;
}

std::string reentry_problem()
{
    if (!in_callback())
        return "";
    return "relief was called from inside a message, progress or cancel callback of a running operation, on "
           "its thread: refused (the running operation holds the device until it returns; call relief after "
           "it, or from another thread)";
}

std::function<void(double)> marked(std::function<void(double)> f)
{
    if (!f)
        return f;
    return [f = std::move(f)](double fraction) {
        const InCallback in;
        f(fraction);
    };
}

std::function<bool()> marked(std::function<bool()> f)
{
    if (!f)
        return f;
    return [f = std::move(f)] {
        const InCallback in;
        return f();
    };
}

std::function<void(Severity, const std::string&)> marked(std::function<void(Severity, const std::string&)> f)
{
    if (!f)
        return f;
    return [f = std::move(f)](Severity s, const std::string& text) {
        const InCallback in;
        f(s, text);
    };
}

Execution paced(const Execution& exec, std::chrono::steady_clock::duration interval)
{
    if (!exec.on_progress)
        return exec;
    using Clock = std::chrono::steady_clock;
    struct Heard {
        std::function<void(double)> progress;
        Clock::time_point at = Clock::now();
        double fraction = 0.0;
        void operator()(double f)
        {
            at = Clock::now();
            fraction = f;
            progress(f);
        }
    };
    auto heard = std::make_shared<Heard>();
    heard->progress = exec.on_progress;
    Execution e = exec;
    e.on_progress = [heard](double f) {
        if (f < 1.0)
            (*heard)(f);
    };
    e.cancel = [heard, interval, cancel = exec.cancel] {
        if (cancel && cancel())
            return true;  // (no heartbeat once the host has asked to stop)
        if (Clock::now() - heard->at < interval)
            return false;
        (*heard)(heard->fraction);
        return cancel && cancel();
    };
    return e;
}

}  // namespace relief::detail
