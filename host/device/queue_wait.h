// SPDX-License-Identifier: Apache-2.0
#pragma once
// Waiting on the device without going deaf. A blocking read or finish
// keeps the operation's thread in the driver for as long as the queue runs,
// so the caller's cancel check, which is also its heartbeat (plugin's
// paced), is not asked meanwhile: a host heard nothing for the whole wait.
// These waits ask this thread's cancel check every few milliseconds while
// they wait. When it says stop, they still wait for the command to complete
// (a read may be writing into the caller's memory, a write reading from it)
// and only then throw Cancelled; the kernels before it are already queued,
// which the stages bound by asking before each one they enqueue.
// OpenCL failures are thrown as cl::Error, as the blocking calls throw them;
// whatever is thrown (a host's callback may throw too) comes only once the
// command has ended.
#include <CL/opencl.hpp>

#include <cstddef>

namespace relief::host {

// Waits until `done` completes (successfully or not), asking the check.
void wait_asking(const cl::Event& done);

// Flushes `queue` and waits for `done`, a command queued on it without
// blocking, as wait_asking does (for a call the helpers below lack, such as
// a rectangular read).
void complete_asking(const cl::CommandQueue& queue, const cl::Event& done);

// queue.finish(), asking the check while it waits.
void finish_asking(const cl::CommandQueue& queue);

// A blocking enqueueReadBuffer / enqueueWriteBuffer, asking the check.
void read_asking(const cl::CommandQueue& queue, const cl::Buffer& buffer, std::size_t offset,
                 std::size_t bytes, void* dst);
void write_asking(const cl::CommandQueue& queue, const cl::Buffer& buffer, std::size_t offset,
                  std::size_t bytes, const void* src);

// A blocking enqueueMapBuffer for reading, asking the check.
void* map_for_reading_asking(const cl::CommandQueue& queue, const cl::Buffer& buffer, std::size_t bytes);

}  // namespace relief::host
