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
#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>
#include <cstdio>
#include <cstring>
int main(int argc, char** argv)
{
    const bool fill = argc < 2 || std::strcmp(argv[1], "write") != 0;
    cl_platform_id p;
    cl_device_id d;
    cl_int err;
    clGetPlatformIDs(1, &p, nullptr);
    clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, 1, &d, nullptr);
    cl_context ctx = clCreateContext(nullptr, 1, &d, nullptr, nullptr, &err);
    cl_command_queue q = clCreateCommandQueue(ctx, d, 0, &err);
    const char* src = "__kernel void twice(__global const float* in, __global float* out) { size_t i = "
                      "get_global_id(0); out[i] = 2.0f * in[i]; }";
    cl_program prog = clCreateProgramWithSource(ctx, 1, &src, nullptr, &err);
    clBuildProgram(prog, 1, &d, "", nullptr, nullptr);
    cl_kernel k = clCreateKernel(prog, "twice", &err);
    const size_t n = 16;
    cl_mem in = clCreateBuffer(ctx, CL_MEM_READ_WRITE, n * sizeof(float), nullptr, &err);
    cl_mem out = clCreateBuffer(ctx, CL_MEM_READ_WRITE, n * sizeof(float), nullptr, &err);
    const float one = 1.0f;
    float ones[n];
    for (size_t i = 0; i < n; ++i)
        ones[i] = 1.0f;
    if (fill)
        clEnqueueFillBuffer(q, in, &one, sizeof one, 0, n * sizeof(float), 0, nullptr, nullptr);
    else
        clEnqueueWriteBuffer(q, in, CL_TRUE, 0, n * sizeof(float), ones, 0, nullptr, nullptr);
    clSetKernelArg(k, 0, sizeof in, &in);
    clSetKernelArg(k, 1, sizeof out, &out);
    clEnqueueNDRangeKernel(q, k, 1, nullptr, &n, nullptr, 0, nullptr, nullptr);
    float r[n];
    clEnqueueReadBuffer(q, out, CL_TRUE, 0, sizeof r, r, 0, nullptr, nullptr);
    std::printf("%s: out[0] = %g\n", fill ? "clEnqueueFillBuffer" : "clEnqueueWriteBuffer", r[0]);
    return 0;
}
