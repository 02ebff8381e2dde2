// SPDX-License-Identifier: Apache-2.0
// The smallest reproducer of an Oclgrind 21.10 crash that relief avoids:
// with --uninitialized on unoptimised code (-cl-opt-disable), a float3
// built from a float2 and a float, `(float3)(o, z)`, kills the simulator
// (SIGSEGV in Uninitialized::instructionExecuted, on the shufflevector that
// widens the float2). `(float3)(o.x, o.y, z)` is the same value and runs.
// relief's correction built its fan's edge vectors so (kernels/correct.cl,
// correct_prepare), which crashed every --correct and --bake under the
// uninitialised-value checks.
//
// Build and run (not part of the test suite):
//   g++ -O1 tests/portability/float3_from_float2.cpp -lOpenCL -o /tmp/float3
//   oclgrind --uninitialized --build-options -cl-opt-disable /tmp/float3        # exit 139
//   oclgrind --uninitialized --build-options -cl-opt-disable /tmp/float3 split  # out = 3
#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>

#include <cstdio>
#include <cstring>

int main(int argc, char** argv)
{
    const bool split = argc > 1 && std::strcmp(argv[1], "split") == 0;
    const char* src = split ? "__kernel void k(__global const float* in, __global float* out)"
                              " { float2 o = (float2)(in[0], in[1]); float3 c = (float3)(o.x, o.y, in[2]);"
                              " out[get_global_id(0)] = c.z; }"
                            : "__kernel void k(__global const float* in, __global float* out)"
                              " { float2 o = (float2)(in[0], in[1]); float3 c = (float3)(o, in[2]);"
                              " out[get_global_id(0)] = c.z; }";
    cl_platform_id p;
    cl_device_id d;
    cl_int err;
    clGetPlatformIDs(1, &p, nullptr);
    clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, 1, &d, nullptr);
    cl_context ctx = clCreateContext(nullptr, 1, &d, nullptr, nullptr, &err);
    cl_command_queue q = clCreateCommandQueue(ctx, d, 0, &err);
    cl_program prog = clCreateProgramWithSource(ctx, 1, &src, nullptr, &err);
    if (clBuildProgram(prog, 1, &d, "", nullptr, nullptr) != CL_SUCCESS) {
        std::fprintf(stderr, "build failed\n");
        return 1;
    }
    cl_kernel k = clCreateKernel(prog, "k", &err);
    float host[3] = {1, 2, 3};
    cl_mem in = clCreateBuffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof host, host, &err);
    cl_mem out = clCreateBuffer(ctx, CL_MEM_READ_WRITE, 8 * sizeof(float), nullptr, &err);
    clSetKernelArg(k, 0, sizeof in, &in);
    clSetKernelArg(k, 1, sizeof out, &out);
    const size_t n = 8;
    clEnqueueNDRangeKernel(q, k, 1, nullptr, &n, nullptr, 0, nullptr, nullptr);
    float r = 0;
    clEnqueueReadBuffer(q, out, CL_TRUE, 0, sizeof r, &r, 0, nullptr, nullptr);
    std::printf("out = %g\n", r);
    return 0;
}
