// SPDX-License-Identifier: Apache-2.0
// The smallest reproducer of an Oclgrind 21.10 fault that relief works
// around: its uninitialised-value plugin (--uninitialized) does not see
// clEnqueueFillBuffer, so every value a kernel reads from a filled buffer is
// reported as uninitialised ("Uninitialized value written to global memory",
// one report per element), though the results are right. The same buffer
// written by clEnqueueWriteBuffer is clean. relief therefore fills buffers
// with a kernel of its own (kernels/device.cl, ComputeContext::Impl::fill),
// which every OpenCL implementation sees as a kernel's stores.
//
// Build and run (not part of the test suite):
//   g++ -O1 tests/portability/fill_buffer.cpp -lOpenCL -o /tmp/fill_buffer
//   oclgrind --uninitialized /tmp/fill_buffer         # 16 reports, out[0] = 2
//   oclgrind --uninitialized /tmp/fill_buffer write   # none
#include <cstdio>
#include <cstring>

#include "first_device.h"

int main(int argc, char** argv)
{
    const bool fill = argc < 2 || std::strcmp(argv[1], "write") != 0;
    const FirstDevice f = open_first_device();
    cl_kernel k =
        clCreateKernel(build_program(f, "__kernel void twice(__global const float* in, __global float* out)"
                                        " { size_t i = get_global_id(0); out[i] = 2.0f * in[i]; }"),
                       "twice", nullptr);
    const size_t n = 16;
    cl_mem in = new_buffer(f, n * sizeof(float)), out = new_buffer(f, n * sizeof(float));
    const float one = 1.0f;
    float ones[n];
    for (size_t i = 0; i < n; ++i)
        ones[i] = 1.0f;
    if (fill)
        clEnqueueFillBuffer(f.queue, in, &one, sizeof one, 0, n * sizeof(float), 0, nullptr, nullptr);
    else
        clEnqueueWriteBuffer(f.queue, in, CL_TRUE, 0, n * sizeof(float), ones, 0, nullptr, nullptr);
    run_in_out(f, k, in, out, n);
    float r[n];
    clEnqueueReadBuffer(f.queue, out, CL_TRUE, 0, sizeof r, r, 0, nullptr, nullptr);
    std::printf("%s: out[0] = %g\n", fill ? "clEnqueueFillBuffer" : "clEnqueueWriteBuffer", r[0]);
    return 0;
}
