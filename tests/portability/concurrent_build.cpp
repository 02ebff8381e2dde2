// SPDX-License-Identifier: Apache-2.0
// The smallest reproducer of Oclgrind 21.10's compiler crash met by relief
// (Debian bookworm's oclgrind package): two threads calling clBuildProgram
// at once. OpenCL allows it, PoCL and Rusticl take it, and Oclgrind's
// Clang/LLVM inside clBuildProgram dies with SIGSEGV (in CodeGenModule's
// constructor, llvm::PointerType::get, or the mangler) in about half the
// runs of relief's --height, whose prepare() thread builds the FFT's
// programs while the main thread builds the DDM's. relief therefore holds
// one process-wide lock around every build (host/device/opencl_context.h,
// compiler_mutex); builds from the binary cache take milliseconds, so only a
// cold process's first builds lose their overlap.
//
// Build and run (not part of the test suite: it crashes the simulator on
// purpose, at random):
//   g++ -O1 -std=c++17 tests/portability/concurrent_build.cpp -lOpenCL -pthread -o /tmp/concurrent_build
//   for i in $(seq 10); do oclgrind /tmp/concurrent_build; echo "exit $?"; done
// With Oclgrind 21.10 every run died (5 of 5: SIGSEGV or SIGABRT, exit 139
// or 134); with `1` as the argument (one build at a time) none did (3 of 3).
#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>

namespace {

// A kernel with enough code that two compilations overlap in time.
std::string source(int variant)
{
    std::string s;
    for (int f = 0; f < 40; ++f)
        s += "float f" + std::to_string(f) + "(float x) { return sin(x) * " + std::to_string(variant + f) +
             ".0f + cos(x * x); }\n";
    s += "__kernel void k(__global float* x) { float v = x[get_global_id(0)];\n";
    for (int f = 0; f < 40; ++f)
        s += "  v = f" + std::to_string(f) + "(v);\n";
    s += "  x[get_global_id(0)] = v; }\n";
    return s;
}

void build(cl_context context, cl_device_id device, int variant)
{
    const std::string text = source(variant);
    const char* p = text.c_str();
    cl_int err = CL_SUCCESS;
    cl_program program = clCreateProgramWithSource(context, 1, &p, nullptr, &err);
    if (err != CL_SUCCESS || clBuildProgram(program, 1, &device, "", nullptr, nullptr) != CL_SUCCESS) {
        std::fprintf(stderr, "build failed\n");
        std::exit(1);
    }
    clReleaseProgram(program);
}

}  // namespace

int main(int argc, char** argv)
{
    const bool serial = argc > 1 && std::string(argv[1]) == "1";
    cl_platform_id platform;
    cl_device_id device;
    if (clGetPlatformIDs(1, &platform, nullptr) != CL_SUCCESS ||
        clGetDeviceIDs(platform, CL_DEVICE_TYPE_ALL, 1, &device, nullptr) != CL_SUCCESS) {
        std::fprintf(stderr, "no OpenCL device\n");
        return 1;
    }
    cl_int err = CL_SUCCESS;
    cl_context context = clCreateContext(nullptr, 1, &device, nullptr, nullptr, &err);
    for (int round = 0; round < 8; ++round) {
        if (serial) {
            build(context, device, 2 * round);
            build(context, device, 2 * round + 1);
        } else {
            std::thread other(build, context, device, 2 * round);
            build(context, device, 2 * round + 1);
            other.join();
        }
    }
    clReleaseContext(context);
    std::puts("built every program");
    return 0;
}
