// SPDX-License-Identifier: Apache-2.0
// Shared by every relief kernel. The host prepends this text to each program,
// so kernels do not #include it (no include paths are needed at run time).
//
// Conventions (docs/design.md §3): x = column (right), y = row (down, as stored);
// images are row-major, texel (x, y) at index y * width + x.

#ifndef RELIEF_KERNELS_COMMON_H
#define RELIEF_KERNELS_COMMON_H

// A helper the compiler must inline: PoCL's CPU back end called large
// helpers, returning their structs through memory (the correction's node
// search, 300 bytes: 0.88x a 1024^2 wall's run once inlined, the same bits).
// Clang-based OpenCL compilers know the attribute; others ignore it. Only
// when optimising: under -cl-opt-disable the forced inliner leaves calls to
// llvm.experimental.noalias.scope.decl, which Oclgrind 21.10 cannot run.
#ifdef __OPTIMIZE__
#define RELIEF_INLINE __attribute__((always_inline)) inline
#else
#define RELIEF_INLINE inline
#endif

// Wraps an integer coordinate into [0, n) for periodic textures; offsets may
// exceed n when a ray is longer than the texture.
// In-range values (the common case) skip the integer division.
inline int relief_wrap(int v, int n)
{
    if ((uint)v < (uint)n)
        return v;
    v %= n;
    return v < 0 ? v + n : v;
}

// A neighbour's coordinate along an axis of n texels: wrapped where the
// axis is periodic, else itself, or -1 where it lies outside [0, n).
inline int relief_wrap_or_out(int v, int n, int periodic)
{
    if (periodic)
        return relief_wrap(v, n);
    return v >= 0 && v < n ? v : -1;
}

// The work-item's cell (*i, *r) of a grid `columns` wide and `rows` tall,
// one item a cell in row-major order, and its index r * columns + i; -1
// for the items past the grid's end (the host rounds the global size up to
// a whole work-group).
inline int relief_grid_cell(int columns, int rows, int* i, int* r)
{
    int gid = get_global_id(0);
    if (gid >= columns * rows)
        return -1;
    *i = gid % columns;
    *r = gid / columns;
    return gid;
}

// The type long sums accumulate in: double where the device has fp64 (the
// host then builds the program with -DRELIEF_FP64), else float (the kernels
// compensate where float alone is too coarse).
#ifdef RELIEF_FP64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double relief_acc_t;
#else
typedef float relief_acc_t;
#endif

// Defines `T name(T x, int n)`: x^n for a whole n >= 0 by squaring, the
// shortest dependency chain (x^5 = (x^2)^2 x). For scalar and vector T; a
// macro so that a program only instantiates the types it uses. The bits
// below 32 are unrolled (theta <= 20 needs no more): llvmpipe counts every
// loop iteration of a work-item against one limit of about 65535 and then
// carries on with wrong values, and this runs once per triangle inside
// loops that the launches size against that limit (loops_fit).
#define RELIEF_DEFINE_POWN(name, T)                                                                          \
    inline T name(T x, int n)                                                                                \
    {                                                                                                        \
        T r = (T)(1), b = x;                                                                                 \
        if (n & 1)                                                                                           \
            r *= b;                                                                                          \
        b *= b;                                                                                              \
        if (n & 2)                                                                                           \
            r *= b;                                                                                          \
        b *= b;                                                                                              \
        if (n & 4)                                                                                           \
            r *= b;                                                                                          \
        b *= b;                                                                                              \
        if (n & 8)                                                                                           \
            r *= b;                                                                                          \
        b *= b;                                                                                              \
        if (n & 16)                                                                                          \
            r *= b;                                                                                          \
        for (n >>= 5; n > 0; n >>= 1) {                                                                      \
            b *= b;                                                                                          \
            if (n & 1)                                                                                       \
                r *= b;                                                                                      \
        }                                                                                                    \
        return r;                                                                                            \
    }

// Defines `void name(T value, local T* scratch, global T* partial)`: the
// work-group's sum of `value` by halving (a power-of-two group size), in a
// fixed order whatever the device (deterministic), into
// partial[group]. `scratch` holds one T per work-item.
#define RELIEF_DEFINE_GROUP_SUM(name, T)                                                                     \
    inline void name(T value, local T* scratch, global T* partial)                                           \
    {                                                                                                        \
        const int lid = get_local_id(0);                                                                     \
        scratch[lid] = value;                                                                                \
        barrier(CLK_LOCAL_MEM_FENCE);                                                                        \
        for (int s = get_local_size(0) / 2; s > 0; s >>= 1) {                                                \
            if (lid < s)                                                                                     \
                scratch[lid] += scratch[lid + s];                                                            \
            barrier(CLK_LOCAL_MEM_FENCE);                                                                    \
        }                                                                                                    \
        if (lid == 0)                                                                                        \
            partial[get_group_id(0)] = scratch[0];                                                           \
    }

#endif
