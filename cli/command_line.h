#pragma once
// Parses relief's oiiotool-like command line into a program of steps.
// Everything is validated before anything runs, so a typo in the last
// argument does not cost a long computation.
#include <OpenImageIO/typedesc.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "relief/bake.h"
#include "relief/correct.h"
#include "relief/errors.h"
#include "relief/height.h"
#include "relief/imageio.h"
#include "relief/slopes.h"

namespace relief::cli {

struct UsageError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

struct Step {
    enum class Kind { Read, Slopes, Height, Correct, Bake, Write } kind;
    std::string text;             // the argument as typed, for messages
    std::string path;             // Read, Write
    OIIO::TypeDesc format;        // Write
    bool format_given = false;    // Write: -d was given (else baked textures keep their type)
    std::string compression;      // Write; empty = relief's default
    SlopeOptions slopes;          // Slopes
    HeightOptions height;         // Height
    std::string mask;             // Height: mask=FILE (read when the step runs)
    CorrectOptions correct;       // Correct
    std::string fix_mask;         // Correct: fix=FILE (read when the step runs)
    BakeOptions bake;             // Bake
};

struct Program {
    std::vector<Step> steps;
    std::string device = "auto";
    std::string report;  // --report FILE.json: the --correct step's report
    bool verbose = false;
    bool help = false;
    bool version = false;
    bool list_devices = false;
};

// Throws UsageError with a one-line explanation.
Program parse_command_line(const std::vector<std::string>& args);

const char* usage_text();

} // namespace relief::cli
