// SPDX-License-Identifier: Apache-2.0
#include "device/queue_wait.h"

#include <chrono>
#include <condition_variable>
#include <exception>
#include <memory>
#include <mutex>

#include "device/cancel.h"

namespace relief::host {

namespace {

// How often a wait asks the check: well inside the heartbeat's 50 ms, so
// that a host hears progress at least every 100 ms while the device works.
constexpr std::chrono::milliseconds kAskEvery{10};

// Set by the event's callback (on a thread of the driver's); shared, so
// that it outlives whichever of the two sides finishes last.
struct Completion {
    std::mutex mutex;
    std::condition_variable changed;
    bool done = false;
};

void CL_CALLBACK on_complete(cl_event, cl_int, void* user)
{
    std::unique_ptr<std::shared_ptr<Completion>> held(static_cast<std::shared_ptr<Completion>*>(user));
    Completion& c = **held;
    {
        std::lock_guard<std::mutex> lock(c.mutex);
        c.done = true;
    }
    c.changed.notify_all();
}

// Complete (CL_COMPLETE, 0) or failed (negative).
bool ended(const cl::Event& e)
{
    return e.getInfo<CL_EVENT_COMMAND_EXECUTION_STATUS>() <= CL_COMPLETE;
}

void throw_if_failed(const cl::Event& done)
{
    const cl_int status = done.getInfo<CL_EVENT_COMMAND_EXECUTION_STATUS>();
    if (status < 0)
        throw cl::Error(status, "clWaitForEvents");
}

// Until `done` has ended, whatever happens (for unwinding: the command may
// use the caller's memory until then).
void wait_regardless(const cl::Event& done) noexcept
{
    try {
        done.wait();
    } catch (...) {
    }
}

// Waits for `done`, asking the check meanwhile: `stop` when it said so,
// `failure` when it threw (a host's callback may), not asked again after
// either. Returns once the command has ended.
void wait_listening(const cl::Event& done, bool& stop, std::exception_ptr& failure)
{
    // (Oclgrind's flush runs the queue to its end, and it calls no callback
    // registered on an event already complete.)
    if (ended(done))
        return;
    auto completion = std::make_shared<Completion>();
    auto held = std::make_unique<std::shared_ptr<Completion>>(completion);
    cl::Event event = done;
    event.setCallback(CL_COMPLETE, on_complete, held.get());  // (it may run at once)
    held.release();
    for (;;) {
        {
            std::unique_lock<std::mutex> lock(completion->mutex);
            if (completion->changed.wait_for(lock, kAskEvery, [&] { return completion->done; }))
                return;
        }
        if (ended(done))  // (a callback late or never called)
            return;
        if (!stop && !failure) {
            try {
                stop = cancel_requested();
            } catch (...) {
                failure = std::current_exception();
            }
        }
    }
}

}  // namespace

void wait_asking(const cl::Event& done)
{
    if (!cancel_check_installed()) {
        try {
            done.wait();
        } catch (const cl::Error&) {
            throw_if_failed(done);  // (the command's own error, not the wait's)
            throw;
        }
        throw_if_failed(done);
        return;
    }
    bool stop = false;
    std::exception_ptr failure;
    try {
        wait_listening(done, stop, failure);
    } catch (...) {
        wait_regardless(done);
        throw;
    }
    if (failure)
        std::rethrow_exception(failure);
    throw_if_failed(done);
    if (stop)
        throw Cancelled();
}

void complete_asking(const cl::CommandQueue& queue, const cl::Event& done)
{
    try {
        queue.flush();
    } catch (...) {
        wait_regardless(done);
        throw;
    }
    wait_asking(done);
}

void finish_asking(const cl::CommandQueue& queue)
{
    cl::Event done;
    queue.enqueueMarkerWithWaitList(nullptr, &done);
    complete_asking(queue, done);
}

void read_asking(const cl::CommandQueue& queue, const cl::Buffer& buffer, std::size_t offset,
                 std::size_t bytes, void* dst)
{
    cl::Event done;
    queue.enqueueReadBuffer(buffer, CL_FALSE, offset, bytes, dst, nullptr, &done);
    complete_asking(queue, done);
}

void write_asking(const cl::CommandQueue& queue, const cl::Buffer& buffer, std::size_t offset,
                  std::size_t bytes, const void* src)
{
    cl::Event done;
    queue.enqueueWriteBuffer(buffer, CL_FALSE, offset, bytes, src, nullptr, &done);
    complete_asking(queue, done);
}

void* map_for_reading_asking(const cl::CommandQueue& queue, const cl::Buffer& buffer, std::size_t bytes)
{
    cl::Event done;
    void* p = queue.enqueueMapBuffer(buffer, CL_FALSE, CL_MAP_READ, 0, bytes, nullptr, &done);
    try {
        complete_asking(queue, done);
    } catch (...) {
        try {  // (the buffer is released unmapped)
            queue.enqueueUnmapMemObject(buffer, p);
            queue.finish();
        } catch (...) {
        }
        throw;
    }
    return p;
}

}  // namespace relief::host
