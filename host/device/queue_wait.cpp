// SPDX-License-Identifier: Apache-2.0
#include "device/queue_wait.h"

#include <chrono>
#include <condition_variable>
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

void throw_if_failed(const cl::Event& done)
{
    const cl_int status = done.getInfo<CL_EVENT_COMMAND_EXECUTION_STATUS>();
    if (status < 0)
        throw cl::Error(status, "clWaitForEvents");
}

}  // namespace

void wait_asking(const cl::Event& done)
{
    if (!cancel_check_installed()) {
        done.wait();
        throw_if_failed(done);
        return;
    }
    auto completion = std::make_shared<Completion>();
    auto held = std::make_unique<std::shared_ptr<Completion>>(completion);
    // (the callback runs, possibly at once, for a command complete or failed)
    cl::Event event = done;
    event.setCallback(CL_COMPLETE, on_complete, held.get());
    held.release();
    bool stop = false;
    std::unique_lock<std::mutex> lock(completion->mutex);
    while (!completion->changed.wait_for(lock, kAskEvery, [&] { return completion->done; })) {
        if (stop)
            continue;
        lock.unlock();
        stop = cancel_requested();
        lock.lock();
    }
    lock.unlock();
    throw_if_failed(done);
    if (stop)
        throw Cancelled();
}

void finish_asking(const cl::CommandQueue& queue)
{
    cl::Event done;
    queue.enqueueMarkerWithWaitList(nullptr, &done);
    queue.flush();
    wait_asking(done);
}

void read_asking(const cl::CommandQueue& queue, const cl::Buffer& buffer, std::size_t offset,
                 std::size_t bytes, void* dst)
{
    cl::Event done;
    queue.enqueueReadBuffer(buffer, CL_FALSE, offset, bytes, dst, nullptr, &done);
    queue.flush();
    wait_asking(done);
}

void write_asking(const cl::CommandQueue& queue, const cl::Buffer& buffer, std::size_t offset,
                  std::size_t bytes, const void* src)
{
    cl::Event done;
    queue.enqueueWriteBuffer(buffer, CL_FALSE, offset, bytes, src, nullptr, &done);
    queue.flush();
    wait_asking(done);
}

void* map_for_reading_asking(const cl::CommandQueue& queue, const cl::Buffer& buffer, std::size_t bytes)
{
    cl::Event done;
    void* p = queue.enqueueMapBuffer(buffer, CL_FALSE, CL_MAP_READ, 0, bytes, nullptr, &done);
    queue.flush();
    try {
        wait_asking(done);
    } catch (const Cancelled&) {
        queue.enqueueUnmapMemObject(buffer, p);  // (the buffer is released unmapped)
        queue.finish();
        throw;
    }
    return p;
}

}  // namespace relief::host
