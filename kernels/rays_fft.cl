// Radial ray integration of periodic textures as one convolution (DESIGN.md
// §4.3, periodic boundaries). common.h is prepended by the host.
//
// A texel's weighted ray sum A(p) is linear in the slopes and, on a torus,
// the same combination of offsets for every p:
//   A(p) = sum over q of Kx(q - p) gx(q) + Ky(q - p) gy(q),
// where segment s of a ray adds its extent times (its own weight / 2 + the
// weights of all later segments) to K at its texel offset. The host builds
// the kernels from the same walk tables as the reference kernel (so the
// answer is the same to rounding), VkFFT transforms them and the slopes,
// and this kernel combines the spectra: H = -(Gx Kx* + Gy Ky*) / W, where
// W is the total weight and Kx* the spectrum of the mirrored kernel.
__kernel void rays_fft_combine(__global float2* gx, __global const float2* gy,
                               __global const float2* kx, __global const float2* ky,
                               int count, float scale)
{
    int i = get_global_id(0);
    if (i >= count)
        return;
    float2 a = gx[i], b = gy[i], u = kx[i], v = ky[i];
    // complex products a*u + b*v
    float re = a.x * u.x - a.y * u.y + b.x * v.x - b.y * v.y;
    float im = a.x * u.y + a.y * u.x + b.x * v.y + b.y * v.x;
    gx[i] = (float2)(re * scale, im * scale);
}
