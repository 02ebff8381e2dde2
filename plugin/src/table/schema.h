// SPDX-License-Identifier: Apache-2.0
#pragma once
// The operation table's schema (internal): how an entry describes an
// operation and its modifiers, and the helpers that build and check them.
// It needs only the option structs (plain data: relief/operation_types.h,
// without OpenImageIO or the operations' functions): each family's entries
// (entries_*.cpp) are written with it, table.cpp gathers them.
#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "options/option_limits.h"
#include "relief/operation_types.h"

namespace relief::table {

using OIIO::ImageBuf;

// A modifier as the table holds it: what users see, and how it reads and
// writes an OperationCall.
struct Modifier {
    ModifierInfo info;
    // Applies a value already checked against `info` (`number` is its
    // numeric value for Integer/Number types, else 0).
    std::function<void(OperationCall&, const std::string& text, double number)> set;
    // The value `call` holds, as the command line writes it.
    std::function<std::string(const OperationCall&)> get;
    // File and Output modifiers: the path `call` names, "" for none (a word
    // such as alpha, or an image given in memory).
    std::function<std::string(const OperationCall&)> path;
};

struct Operation {
    OperationInfo info;
    std::vector<Modifier> modifiers;
    // Checks combinations once every given modifier is set (`given`: key -> text).
    // Rules about what was written (`given`: key -> text), once every given
    // modifier is set; the rules on values are validate()'s.
    std::function<void(OperationCall&, const std::map<std::string, std::string>& given,
                       const std::vector<Modifier>& modifiers)>
        finish;
    // relief::validate() of the call's options: "" or the broken rule.
    std::function<std::string(const OperationCall&)> validate;
    std::function<bool(ImageBuf&, const OperationCall&, const std::vector<const ImageBuf*>&)> run;
    std::function<bool(const OperationCall&)> sets_up_ahead;  // empty: never
    // Over a UDIM set: whether the call takes every tile at once, and the
    // run that does (one input per tile, numbered by `tiles`).
    std::function<bool(const OperationCall&)> joins_tiles;  // empty: never
    std::function<bool(std::vector<ImageBuf>&, const OperationCall&, const std::vector<int>& tiles,
                       const std::vector<const ImageBuf*>&)>
        run_tiles;
    std::function<std::string(const OperationCall&)> describe;  // empty: nothing to add
    // Throws, with the numbers, when the call's estimate for a width x
    // height map does not fit the device and the machine (known before any
    // work); empty: no estimate beyond the float result's.
    std::function<void(const OperationCall&, int width, int height)> check_memory;
};

using detail::number_text;
bool in_range(const ModifierInfo& m, double v);
std::string joined(const std::vector<std::string>& v, const char* sep);
// "a, b and c"
std::string listed(const std::vector<std::string>& names);
// A file modifier's word with arguments ("height:H0:DH"): the prefix it starts with.
std::string word_prefix(const std::string& word);
// A finite number written in full ("1.5", "-2e3"); false for anything else.
bool read_number(const std::string& text, double& v);
// Checks `text` against m; returns its number (Integer/Number), else 0.
// Throws std::invalid_argument.
double check_value(const ModifierInfo& m, const std::string& text);

// ---- modifier builders -----------------------------------------------------
// `field` is a generic lambda returning a reference to the option it sets,
// for a const or non-const OperationCall.

template <class F, class E>
Modifier choice(const char* name, F field, std::vector<std::pair<std::string, E>> names,
                const char* applies_to, const char* meaning)
{
    Modifier m;
    m.info.name = name;
    m.info.type = ModifierType::Choice;
    for (const auto& n : names)
        m.info.choices.push_back(n.first);
    m.info.applies_to = applies_to;
    m.info.meaning = meaning;
    m.set = [field, names](OperationCall& c, const std::string& text, double) {
        for (const auto& n : names)
            if (n.first == text)
                field(c) = n.second;
    };
    m.get = [field, names](const OperationCall& c) {
        for (const auto& n : names)
            if (n.second == field(c))
                return n.first;
        return std::string("?");
    };
    return m;
}

inline const std::vector<std::pair<std::string, bool>> kOnOff = {{"on", true}, {"off", false}};

// boundary=: one word for both axes, or x's and y's ("periodic,free": the
// map wraps from its right edge to its left, not from its bottom to its top).
inline const std::vector<std::pair<std::string, Boundaries>> kBoundaryWords = {
    {"auto", Boundary::Auto},
    {"periodic", Boundary::Periodic},
    {"free", Boundary::Free},
    {"periodic,free", {Boundary::Periodic, Boundary::Free}},
    {"free,periodic", {Boundary::Free, Boundary::Periodic}}};

// An Integer or Number modifier within `limits` (its zero word, "auto",
// stands for 0).
template <class F>
Modifier number(const detail::Limits& limits, F field, const char* placeholder, const char* applies_to,
                const char* meaning)
{
    Modifier m;
    m.info.name = limits.name;
    m.info.type = limits.integer ? ModifierType::Integer : ModifierType::Number;
    std::vector<std::pair<std::string, double>> words;
    if (limits.zero_word) {
        words.emplace_back(limits.zero_word, 0.0);
        m.info.choices.push_back(limits.zero_word);
    }
    m.info.min = limits.min;
    m.info.max = limits.max;
    m.info.min_open = limits.min_open;
    m.info.max_open = limits.max_open;
    m.info.placeholder = placeholder;
    m.info.unit = limits.unit;
    m.info.applies_to = applies_to;
    m.info.meaning = meaning;
    const ModifierInfo info = m.info;
    m.set = [field, words, info](OperationCall& c, const std::string& text, double v) {
        using T = std::decay_t<decltype(field(c))>;
        bool word = false;
        for (const auto& w : words)
            if (w.first == text) {
                v = w.second;
                word = true;
            }
        field(c) = T(v);
        // A value inside the range can round onto an excluded end (phase=0.99999999 -> 1).
        if (!word && !in_range(info, double(field(c))))
            throw std::invalid_argument(info.name + "=" + text + " is " + number_text(double(field(c))) +
                                        " in single precision, outside " + range_text(info));
    };
    m.get = [field, words](const OperationCall& c) {
        const double v = double(field(c));
        for (const auto& w : words)
            if (w.second == v)
                return w.first;
        return number_text(v);
    };
    return m;
}

// normal, max_angle, range: shared by every operation that decodes normals.
template <class F>
std::vector<Modifier> decoding_modifiers(F decoding)
{
    return {
        choice(
            "normal", [decoding](auto& c) -> auto& { return decoding(c).convention; },
            std::vector<std::pair<std::string, NormalConvention>>{{"auto", NormalConvention::Auto},
                                                                  {"opengl", NormalConvention::OpenGL},
                                                                  {"directx", NormalConvention::DirectX}},
            "", "green convention: opengl (Y+), directx (Y-), auto: the one with less curl"),
        number(
            detail::limits::max_angle, [decoding](auto& c) -> auto& { return decoding(c).max_angle; }, "DEG",
            "", "clamp grazing normals to this angle from +z"),
        choice(
            "range", [decoding](auto& c) -> auto& { return decoding(c).float_encoding; },
            std::vector<std::pair<std::string, FloatEncoding>>{{"signed", FloatEncoding::Signed},
                                                               {"unsigned", FloatEncoding::Unsigned}},
            "", "float/half normals stored in [-1,1] (signed) or [0,1] (unsigned)"),
    };
}

// The image of a file modifier (mask=FILE, fix=FILE): `given` when the
// caller read it already (the command line reads quietly), else read into
// `storage`; nullptr when there is none.
const ImageBuf* file_image(const ImageBuf* given, const std::string& path, const char* what,
                           ImageBuf& storage);

// Stands for the image of a file modifier (mask=FILE, fix=FILE) when a
// parsed call is validated: the file is read only when the call runs.
const ImageBuf& file_to_come();

extern const ImageSlot kNormals, kHeight;

// The entries, by family: entries_height.cpp (slopes, height),
// entries_correct.cpp (correct, bake), entries_check.cpp (normals,
// tessellation, mesh, preview).
Operation slopes_operation();
Operation height_operation();
Operation correct_operation();
Operation bake_operation();
Operation normals_operation();
Operation tessellation_operation();
Operation mesh_operation();
Operation preview_operation();

// The table: every entry, defaults filled in from the option structs.
const std::vector<Operation>& entries();
// nullptr when there is no such operation.
const Operation* find(const std::string& name);
// Throws std::invalid_argument naming the known operations.
const Operation& find_or_throw(const std::string& name);

}  // namespace relief::table
