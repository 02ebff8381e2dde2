// SPDX-License-Identifier: Apache-2.0
#pragma once
// The operation table's data (relief/operations.h): how an operation, its
// images and its modifiers are described, and one call of an operation with
// its options. Plain data on the option structs (*_types.h), no
// OpenImageIO: the table's schema and its entries build on it.
#include <string>
#include <vector>

#include "relief/bake_types.h"
#include "relief/check_types.h"
#include "relief/correct_types.h"
#include "relief/export.h"
#include "relief/height_types.h"
#include "relief/mesh_types.h"
#include "relief/options.h"
#include "relief/preview_types.h"
#include "relief/slopes_types.h"

namespace relief {

// Choice: one of `choices`. Integer, Number: a value in [min, max] (an end
// is excluded when its *_open flag is set), or one of `choices` (words such
// as "auto"). File: a path to an image, or one of `choices` ("alpha").
// Output: a path the operation writes (its folder must exist). Text: a value
// with a syntax of its own, given by `placeholder` ("AZ,EL").
enum class ModifierType { Choice, Integer, Number, File, Output, Text };

struct ModifierInfo {
    std::string name;
    ModifierType type = ModifierType::Choice;
    std::vector<std::string> choices;
    double min = 0.0, max = 0.0;
    bool min_open = false, max_open = false;
    std::string placeholder;    // how --help writes a value: "J", "DEG", "FILE"
    std::string unit;           // of Integer/Number values: "texels", "degrees", ""
    std::string default_value;  // as the command line writes it
    std::string applies_to;     // "" (always) or the setting it needs: "method=rays"
    std::string meaning;        // one line
};

// One image an operation takes or gives, with the channel counts it accepts.
struct ImageSlot {
    std::string name;
    int min_channels = 1, max_channels = 4;
    std::string meaning;
};

struct OperationInfo {
    std::string name;               // "height": the command line's --height
    std::string summary;            // one line
    std::vector<ImageSlot> inputs;  // in the order they are pushed (the top last)
    std::vector<ImageSlot> outputs;
    std::vector<ModifierInfo> modifiers;
    std::string report;  // the key of the object it adds to --report ("" = none)
};

// "[1, 4096]", "(0, 90) degrees": the values an Integer/Number modifier takes.
RELIEF_API std::string range_text(const ModifierInfo& modifier);

// One call of an operation: its options as parsed from modifiers. Only the
// member named by `operation` is used.
struct OperationCall {
    std::string operation;
    SlopeOptions slopes;
    HeightOptions height;
    CorrectOptions correct;
    BakeOptions bake;
    NormalsOptions normals;
    TessellationOptions tessellation;
    MeshOptions mesh;
    PreviewOptions preview;
    std::string mask_file;  // height: mask=FILE, read by run_operation() unless height.mask is set
    std::string fix_file;   // correct: fix=FILE, read by run_operation() unless correct.fix_mask is set
    // Set by the caller, for an operation with a report (OperationInfo::
    // report): run_operation() writes the report there as a JSON object.
    std::string* report_json = nullptr;
    // Recorded in the file an operation writes (an Output modifier's), as
    // the relief:digest an -o image records: what --update compares.
    std::string file_digest;
};

}  // namespace relief
