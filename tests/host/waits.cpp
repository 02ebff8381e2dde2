// SPDX-License-Identifier: Apache-2.0
// Host layer: waiting on the device, and on a call that cannot ask by
// itself, while the caller's cancel check is asked (host/device/
// queue_wait.h, run_asking in host/device/cancel.h): the check is asked
// during the wait, and a cancel takes effect only once the command (or the
// call) is over, never while it may still touch the caller's memory.
#include <catch2/catch.hpp>

#include <atomic>
#include <chrono>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include "device/cancel.h"
#include "device/compute_context.h"
#include "device/opencl_context.h"
#include "device/queue_wait.h"

namespace {

using WaitClock = std::chrono::steady_clock;

double seconds_since(WaitClock::time_point t)
{
    return std::chrono::duration<double>(WaitClock::now() - t).count();
}

// A read of `buffer` queued behind a gate the test opens after `delay`:
// the read cannot complete before then.
struct GatedQueue {
    relief::host::ComputeContext::Impl& c;
    std::lock_guard<std::mutex> lock;
    cl::UserEvent gate;
    explicit GatedQueue(relief::host::ComputeContext& ctx) : c(ctx.impl()), lock(c.mutex), gate(c.context)
    {
        std::vector<cl::Event> after{gate};
        c.queue.enqueueMarkerWithWaitList(&after);
    }
    std::thread open_after(std::chrono::milliseconds delay)
    {
        return std::thread([this, delay] {
            std::this_thread::sleep_for(delay);
            gate.setStatus(CL_COMPLETE);
        });
    }
};

}  // namespace

TEST_CASE("a read from the device asks the cancel check while it waits, and a cancel comes after the read",
          "[host][cancel]")
{
    auto ctx = relief::host::ComputeContext::acquire("auto");
    const std::vector<float> values{1.5f, -2.0f, 3.25f, 7.0f};
    cl::Buffer buffer(ctx->impl().context, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR,
                      sizeof(float) * values.size(), const_cast<float*>(values.data()));
    std::atomic<int> asks{0};
    bool stop = false;
    const relief::host::CancelCheck check([&] {
        ++asks;
        return stop;
    });
    GatedQueue q(*ctx);
    std::vector<float> got(values.size(), 0.0f);

    SECTION("not cancelled: the values, the check asked every few ms meanwhile")
    {
        std::thread opener = q.open_after(std::chrono::milliseconds(300));
        const auto t0 = WaitClock::now();
        relief::host::read_asking(q.c.queue, buffer, 0, sizeof(float) * values.size(), got.data());
        const double waited = seconds_since(t0);
        opener.join();
        CHECK(waited >= 0.29);
        CHECK(got == values);
        CHECK(asks >= 5);  // (every 10 ms: about 30)
    }
    SECTION("cancelled: Cancelled, thrown only once the read is done")
    {
        stop = true;
        std::thread opener = q.open_after(std::chrono::milliseconds(300));
        const auto t0 = WaitClock::now();
        CHECK_THROWS_AS(
            relief::host::read_asking(q.c.queue, buffer, 0, sizeof(float) * values.size(), got.data()),
            relief::host::Cancelled);
        const double waited = seconds_since(t0);  // (before the gate's thread is joined)
        opener.join();
        CHECK(waited >= 0.29);
        CHECK(got == values);
        CHECK(asks == 1);  // (not asked again once it said stop)
    }
    SECTION("finish: the same")
    {
        std::thread opener = q.open_after(std::chrono::milliseconds(300));
        const auto t0 = WaitClock::now();
        relief::host::finish_asking(q.c.queue);
        CHECK(seconds_since(t0) >= 0.29);
        CHECK(asks >= 5);
        opener.join();
    }
}

TEST_CASE("a wait with no cancel check installed just waits", "[host][cancel]")
{
    auto ctx = relief::host::ComputeContext::acquire("auto");
    GatedQueue q(*ctx);
    std::thread opener = q.open_after(std::chrono::milliseconds(100));
    const auto t0 = WaitClock::now();
    relief::host::finish_asking(q.c.queue);
    const double waited = seconds_since(t0);
    opener.join();
    CHECK(waited >= 0.09);
}

TEST_CASE("run_asking: the call runs elsewhere while the check is asked; a cancel after it ends",
          "[host][cancel]")
{
    std::atomic<int> asks{0};
    std::atomic<bool> stop_now{false};
    const relief::host::CancelCheck check([&] {
        ++asks;
        return stop_now.load();
    });
    SECTION("to its end")
    {
        bool ran = false;
        relief::host::run_asking([&](const std::atomic<bool>& stop) {
            std::this_thread::sleep_for(std::chrono::milliseconds(200));
            ran = !stop.load();
        });
        CHECK(ran);
        CHECK(asks >= 5);
    }
    SECTION("a call that looks at stop ends early; Cancelled")
    {
        std::atomic<bool> ended{false};
        const auto t0 = WaitClock::now();
        CHECK_THROWS_AS(relief::host::run_asking([&](const std::atomic<bool>& stop) {
                            stop_now = true;
                            while (!stop.load())
                                std::this_thread::sleep_for(std::chrono::milliseconds(1));
                            ended = true;
                            throw std::runtime_error("stopped");
                        }),
                        relief::host::Cancelled);
        CHECK(ended);
        CHECK(seconds_since(t0) < 5.0);
    }
    SECTION("a call that does not look runs to its end, then Cancelled")
    {
        bool finished = false;
        CHECK_THROWS_AS(relief::host::run_asking([&](const std::atomic<bool>&) {
                            stop_now = true;
                            std::this_thread::sleep_for(std::chrono::milliseconds(100));
                            finished = true;
                        }),
                        relief::host::Cancelled);
        CHECK(finished);
    }
    SECTION("its own failure comes through")
    {
        CHECK_THROWS_WITH(
            relief::host::run_asking([](const std::atomic<bool>&) { throw std::runtime_error("disk full"); }),
            "disk full");
    }
}
