// SPDX-License-Identifier: Apache-2.0
// Device behaviour that no OpenCL query reports, probed once per context
// (host/device/compute_context.cpp).

// A work-item runs n steps of a recurrence the compiler cannot fold; the
// host compares the result with its own. Mesa's llvmpipe (Rusticl) ends a
// work-item's loops after about 65535 iterations in all and carries on with
// the wrong values, without an error: the host finds that limit with this
// kernel, and stages whose work-items could loop longer take another launch
// shape there, or refuse.
__kernel void device_loop_probe(uint seed, uint n, __global uint* out)
{
    uint x = seed;
    for (uint k = 0; k < n; ++k)
        x = x * 1664525u + 1013904223u;
    out[0] = x;
}

// Sets `count` 32-bit words from `first` on to `pattern`: relief's own
// clEnqueueFillBuffer (host/device/compute_context.cpp, fill), because Oclgrind's
// uninitialised-value checks do not see that call and report every value
// read from a filled buffer (tests/portability/fill_buffer.cpp).
__kernel void device_fill_words(__global uint* words, uint first, uint count, uint pattern)
{
    const uint i = get_global_id(0);
    if (i < count)
        words[first + i] = pattern;
}

// The same for single bytes.
__kernel void device_fill_bytes(__global uchar* bytes, uint first, uint count, uchar pattern)
{
    const uint i = get_global_id(0);
    if (i < count)
        bytes[first + i] = pattern;
}
