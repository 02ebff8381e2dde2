// SPDX-License-Identifier: Apache-2.0
// The smallest reproducer of an Oclgrind 21.10 fault that relief works
// around: its uninitialised-value plugin (--uninitialized) keeps, per
// buffer number, the record of which bytes were written, and does not drop
// it when the buffer is released. The next buffer that gets the same number
// inherits the old record: past the old buffer's size, the kernels' stores
// are not recorded and every load is reported as uninitialised, though a
// kernel wrote it. Any program that frees a small buffer and then makes a
// larger one meets it; relief did in every stage after the DDM (its 8-byte
// counters, then the transforms' grids). relief writes each new buffer once
// from the host on a simulator (quiet NaNs: ComputeContext::Impl::poison),
// which gives it a record of its own size and makes a read of what no
// kernel wrote show as NaN in the result.
//
// Build and run (not part of the test suite):
//   g++ -O1 tests/portability/reused_buffer.cpp -lOpenCL -o /tmp/reused_buffer
//   oclgrind --uninitialized /tmp/reused_buffer          # reports, out[15] = 2
//   oclgrind --uninitialized /tmp/reused_buffer fresh    # none
#include <cstdio>
#include <cstring>

#include "first_device.h"

int main(int argc, char** argv)
{
    const bool reuse = argc < 2 || std::strcmp(argv[1], "fresh") != 0;
    const FirstDevice f = open_first_device();
    cl_program prog =
        build_program(f, "__kernel void ones(__global float* b) { b[get_global_id(0)] = 1.0f; }\n"
                         "__kernel void twice(__global const float* in, __global float* out)"
                         " { size_t i = get_global_id(0); out[i] = 2.0f * in[i]; }\n");
    cl_kernel ones = clCreateKernel(prog, "ones", nullptr), twice = clCreateKernel(prog, "twice", nullptr);
    if (reuse) {  // a 4-byte buffer a kernel writes, then released
        cl_mem small = new_buffer(f, 4);
        clSetKernelArg(ones, 0, sizeof small, &small);
        const size_t one = 1;
        clEnqueueNDRangeKernel(f.queue, ones, 1, nullptr, &one, nullptr, 0, nullptr, nullptr);
        clFinish(f.queue);
        clReleaseMemObject(small);
    }
    const size_t n = 16;
    cl_mem in = new_buffer(f, n * sizeof(float)), out = new_buffer(f, n * sizeof(float));
    clSetKernelArg(ones, 0, sizeof in, &in);
    clEnqueueNDRangeKernel(f.queue, ones, 1, nullptr, &n, nullptr, 0, nullptr,
                           nullptr);  // writes all of `in`
    run_in_out(f, twice, in, out, n);
    float r[n];
    clEnqueueReadBuffer(f.queue, out, CL_TRUE, 0, sizeof r, r, 0, nullptr, nullptr);
    std::printf("%s: out[15] = %g\n", reuse ? "after a released buffer" : "fresh buffers", r[15]);
    return 0;
}
