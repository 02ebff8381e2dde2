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
#include <cstdio>
#include <cstring>

#include "first_device.h"

int main(int argc, char** argv)
{
    const bool split = argc > 1 && std::strcmp(argv[1], "split") == 0;
    const char* src = split ? "__kernel void k(__global const float* in, __global float* out)"
                              " { float2 o = (float2)(in[0], in[1]); float3 c = (float3)(o.x, o.y, in[2]);"
                              " out[get_global_id(0)] = c.z; }"
                            : "__kernel void k(__global const float* in, __global float* out)"
                              " { float2 o = (float2)(in[0], in[1]); float3 c = (float3)(o, in[2]);"
                              " out[get_global_id(0)] = c.z; }";
    const FirstDevice f = open_first_device();
    cl_program prog = build_program(f, src);
    if (!prog) {
        std::fprintf(stderr, "build failed\n");
        return 1;
    }
    cl_kernel k = clCreateKernel(prog, "k", nullptr);
    float host[3] = {1, 2, 3};
    cl_mem in =
        clCreateBuffer(f.context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof host, host, nullptr);
    cl_mem out = new_buffer(f, 8 * sizeof(float));
    run_in_out(f, k, in, out, 8);
    float r = 0;
    clEnqueueReadBuffer(f.queue, out, CL_TRUE, 0, sizeof r, &r, 0, nullptr, nullptr);
    std::printf("out = %g\n", r);
    return 0;
}
