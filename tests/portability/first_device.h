// SPDX-License-Identifier: Apache-2.0
// What each reproducer in this folder needs before its few lines of
// interest: the first device of the first platform, a context and an
// in-order queue, and a program built from one source string. Kept as
// plain C calls without error handling, so that a reproducer stays what an
// OpenCL implementation's maintainers can read in one screen.
#pragma once
#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>

struct FirstDevice {
    cl_platform_id platform;
    cl_device_id device;
    cl_context context;
    cl_command_queue queue;
};

inline FirstDevice open_first_device()
{
    FirstDevice f;
    cl_int err;
    clGetPlatformIDs(1, &f.platform, nullptr);
    clGetDeviceIDs(f.platform, CL_DEVICE_TYPE_ALL, 1, &f.device, nullptr);
    f.context = clCreateContext(nullptr, 1, &f.device, nullptr, nullptr, &err);
    f.queue = clCreateCommandQueue(f.context, f.device, 0, &err);
    return f;
}

// The program from `src`, or null where it does not build.
inline cl_program build_program(const FirstDevice& f, const char* src)
{
    cl_int err;
    cl_program prog = clCreateProgramWithSource(f.context, 1, &src, nullptr, &err);
    return clBuildProgram(prog, 1, &f.device, "", nullptr, nullptr) == CL_SUCCESS ? prog : nullptr;
}

inline cl_mem new_buffer(const FirstDevice& f, size_t bytes)
{
    cl_int err;
    return clCreateBuffer(f.context, CL_MEM_READ_WRITE, bytes, nullptr, &err);
}

// Runs `k` over n items with `in` and `out` as its two arguments.
inline void run_in_out(const FirstDevice& f, cl_kernel k, cl_mem in, cl_mem out, size_t n)
{
    clSetKernelArg(k, 0, sizeof in, &in);
    clSetKernelArg(k, 1, sizeof out, &out);
    clEnqueueNDRangeKernel(f.queue, k, 1, nullptr, &n, nullptr, 0, nullptr, nullptr);
}
