// SPDX-License-Identifier: Apache-2.0
#pragma once
// Option structs shared by relief's operations. Defaults are the documented
// defaults of the command line. Options only point to images, so the image
// type is declared here, not included: the option structs (*_types.h) are
// plain data that the operation table's schema builds on.
#include <OpenImageIO/oiioversion.h>

#include <functional>
#include <string>

OIIO_NAMESPACE_BEGIN
class ImageBuf;
OIIO_NAMESPACE_END

namespace relief {

// Which way the green channel of a tangent-space normal map points
// (Substance's names): OpenGL = Y+ (green points to the top of the image),
// DirectX = Y- (green points down). Auto picks the convention whose slope
// field has the smaller curl and reports both curl norms.
enum class NormalConvention { Auto, OpenGL, DirectX };

// How float/half normal maps store their components: Signed = as stored, in
// [-1, 1]; Unsigned = in [0, 1], decoded as 2v - 1 like UNORM integers.
// Integer images are always UNORM (2v - 1).
enum class FloatEncoding { Signed, Unsigned };

struct NormalDecoding {
    NormalConvention convention = NormalConvention::Auto;
    // Normals tilted more than this (degrees from +z) are clamped to it, so
    // slopes stay finite (tan(85°) = 11.4 texel per texel).
    float max_angle = 85.0f;
    FloatEncoding float_encoding = FloatEncoding::Signed;
};

// A value for each axis of a texture, x (columns) first: one value sets
// both axes, and compared with one value both axes must have it
// (`o.boundary = Boundary::Free`). E's first value is the default.
template <class E>
struct PerAxis {
    E x = E{}, y = E{};
    constexpr PerAxis(E both = E{}) : x(both), y(both) {}
    constexpr PerAxis(E along_x, E along_y) : x(along_x), y(along_y) {}
    friend constexpr bool operator==(const PerAxis& a, const PerAxis& b) { return a.x == b.x && a.y == b.y; }
    friend constexpr bool operator!=(const PerAxis& a, const PerAxis& b) { return !(a == b); }
};

// Debug: what the libraries relief uses said (the image library's own
// diagnostics); Info: details (device, counts); Notice: a choice made for
// the user that they should see (the auto-detected convention); Warning:
// likely trouble.
enum class Severity { Debug, Info, Notice, Warning };

struct Execution {
    // OpenCL device: "auto" (a GPU if there is one, else the CPU), "gpu",
    // "cpu" or "<platform>:<device>" (indices as `relief --list-devices` shows).
    std::string device = "auto";
    // Receives what an operation chose and any warning (one line each).
    // Without it nothing is printed; the result's metadata records the same.
    std::function<void(Severity, const std::string&)> on_message;
    // Fraction done in [0, 1], never falling. Through the table
    // (run_operation: the command line, the C ABI, Python) 0 first and 1
    // last, once the result is complete, and the last fraction again when
    // a stage asks cancel 50 ms or more after the last report.
    std::function<void(double)> on_progress;
    // Asked before each kernel is queued, between the parts of a long
    // pass and between host passes (and at the operation's set-up): true
    // stops the operation there, within one kernel's or part's time. It then
    // fails with geterror() "<operation>: cancelled", writes nothing and
    // keeps nothing. Called on the operation's thread.
    // None of the three may start a relief operation on that thread (the
    // running one holds the device): such a call fails at once, geterror()
    // saying why, and the running operation goes on.
    std::function<bool()> cancel;
};

}  // namespace relief
