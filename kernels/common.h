// SPDX-License-Identifier: Apache-2.0
// Shared by every relief kernel. The host prepends this text to each program,
// so kernels do not #include it (no include paths are needed at run time).
//
// Conventions (docs/design.md §3): x = column (right), y = row (down, as stored);
// images are row-major, texel (x, y) at index y * width + x.

#ifndef RELIEF_KERNELS_COMMON_H
#define RELIEF_KERNELS_COMMON_H

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

#endif
