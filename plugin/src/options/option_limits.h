// SPDX-License-Identifier: Apache-2.0
#pragma once
// The values each numeric option takes, written once. The operation table
// builds its modifiers from these (what --help, the JSON listing and the
// command line's parser show and accept); validate() holds the option
// structs to them (what the C++ API, the C ABI and Python accept); both
// word a value outside them with out_of_range().
#include <string>

namespace relief::detail {

struct Limits {
    const char* name;  // as the command line writes it
    bool integer;
    double min;
    bool min_open;  // min itself is excluded
    double max;
    bool max_open;
    const char* unit;       // "", "texels", "degrees", ...
    const char* zero_word;  // the word 0 stands for ("auto": chosen later), or nullptr
};

namespace limits {
// normal map decoding
inline constexpr Limits max_angle{"max_angle", false, 0, true, 90, true, "degrees", nullptr};
// height
inline constexpr Limits highpass{"highpass", false, 0, false, 1e9, false, "texels", nullptr};
inline constexpr Limits rays{"rays", true, 1, false, 4096, false, "", nullptr};
inline constexpr Limits radius{"radius", false, 0, true, 65536, false, "texels", nullptr};
inline constexpr Limits phase{"phase", false, 0, false, 1, true, "", nullptr};
// correct
inline constexpr Limits displacement_scale{"scale", false, 0, true, 1e9, false, "", "auto"};
inline constexpr Limits theta{"theta", false, 0, false, 20, false, "", nullptr};
inline constexpr Limits iterations{"iterations", true, 1, false, 1000000, false, "", "auto"};
inline constexpr Limits tolerance{"tolerance", false, 0, true, 1, true, "", nullptr};
inline constexpr Limits levels{"levels", true, 1, false, 30, false, "", "auto"};
inline constexpr Limits threshold{"threshold", false, 0, false, 1e9, false, "", nullptr};
inline constexpr Limits relax{"relax", false, 1, false, 2, true, "", nullptr};
inline constexpr Limits polish{"polish", true, 0, false, 1000, false, "", nullptr};
// normals, tessellation, mesh: the surface is scale x height
inline constexpr Limits surface_scale{"scale", false, 0, true, 1e9, false, "", nullptr};
inline constexpr Limits patch{"patch", true, 1, false, 4096, false, "texels", nullptr};
inline constexpr Limits error{"error", false, 0, true, 1e9, false, "texels x S", nullptr};
// correct's fix=height:H0:DH (DH 0: no tent)
inline constexpr Limits fix_height{"fix height", false, -1e30, false, 1e30, false, "", nullptr};
inline constexpr Limits fix_width{"fix width", false, 0, true, 1e30, false, "", "none"};
// preview's light=AZ,EL
inline constexpr Limits light_azimuth{"azimuth", false, -360, false, 360, false, "degrees", nullptr};
inline constexpr Limits light_elevation{"elevation", false, 0, true, 90, false, "degrees", nullptr};
}  // namespace limits

// Integers as integers (1000000, not 1e+06); else the shortest text that
// reads back as the same float.
std::string number_text(double v);
// "[1, 4096]", "(0, 90) degrees"
std::string range_text(double min, bool min_open, double max, bool max_open, const std::string& unit);
std::string range_text(const Limits& l);
// Inside the range, or the zero word's 0.
bool within(const Limits& l, double v);
// The one wording of a value outside its range: "rays=0 must be an integer
// in [1, 4096]", "phase=1 is out of range; it must be in [0, 1)" (`words`:
// "auto" or "a|b", appended as " or auto").
std::string out_of_range(const std::string& name, const std::string& value, bool integer,
                         const std::string& range, const std::string& words);
// The one wording of a choice outside its words: "normal=auto is not one of
// opengl|directx" (`choices`: "a|b|c").
std::string not_one_of(const std::string& name, const std::string& value, const std::string& choices);
// "phase=nan is not a number"
std::string not_a_number(const std::string& name, const std::string& value);
// out_of_range() (or not_a_number()) for v, or "" when it is within.
std::string range_problem(const Limits& l, double v);

}  // namespace relief::detail
