// SPDX-License-Identifier: Apache-2.0
#include "command_line.h"

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <filesystem>
#include <tuple>
#include <utility>

#include "relief/output_files.h"

namespace relief::cli {

namespace fs = std::filesystem;

namespace {

constexpr std::size_t kColumn = 24, kWidth = 79;

// "  left      text..." with text wrapped at kWidth and continued at kColumn.
std::string help_line(const std::string& left, const std::string& text)
{
    std::string out = left;
    std::size_t col = left.size();
    if (col + 1 >= kColumn) {
        out += "\n";
        col = 0;
    }
    out += std::string(kColumn - col, ' ');
    col = kColumn;
    std::size_t pos = 0;
    bool first = true;
    while (pos < text.size()) {
        std::size_t end = text.find(' ', pos);
        if (end == std::string::npos)
            end = text.size();
        const std::string word = text.substr(pos, end - pos);
        if (!first && col + 1 + word.size() > kWidth) {
            out += "\n" + std::string(kColumn, ' ');
            col = kColumn;
        } else if (!first) {
            out += ' ';
            ++col;
        }
        out += word;
        col += word.size();
        first = false;
        pos = end + 1;
    }
    return out + "\n";
}

std::string values_text(const ModifierInfo& m)
{
    std::string words;
    for (const auto& c : m.choices)
        words += (words.empty() ? "" : "|") + c;
    if (m.type == ModifierType::Choice)
        return words;
    return words.empty() ? m.placeholder : m.placeholder + "|" + words;
}

std::string range_help(const ModifierInfo& m)
{
    if (m.type != ModifierType::Integer && m.type != ModifierType::Number)
        return "";
    return std::string(m.type == ModifierType::Integer ? "; an integer in " : "; in ") + range_text(m);
}

std::string operations_help()
{
    std::string out = "Operations (from the stack's top; each pops its inputs and pushes its result):\n";
    for (const OperationInfo& op : operations()) {
        std::string inputs;
        for (const ImageSlot& in : op.inputs)
            inputs += (inputs.empty() ? "" : ", ") + in.name;
        out += help_line("  --" + op.name + "[:MODS]", op.summary + ". Pops " + inputs + ".");
    }
    for (const OperationInfo& op : operations()) {
        out += "Modifiers (:key=value) of --" + op.name + ":\n";
        std::string group;
        for (const ModifierInfo& m : op.modifiers) {
            if (m.applies_to != group) {
                group = m.applies_to;
                if (!group.empty())
                    out += "  with " + group + ":\n";
            }
            const std::string indent = group.empty() ? "  " : "    ";
            out += help_line(indent + m.name + "=" + values_text(m),
                             m.meaning + range_help(m) + " (default " + m.default_value + ")");
        }
    }
    return out;
}

} // namespace

const std::string& usage_text()
{
    static const std::string text = std::string(R"(relief — normal maps to displacement maps (OpenCL)

Usage: relief [options] ARG...
Arguments are read left to right over a stack of images, like oiiotool:
  FILE                  push an image (read as raw data, no colour conversion)
  --OPERATION[:MODS]    pop the operation's inputs, push its result
  -o FILE               write the top of the stack (atomically)
  --dup                 push a copy of the top image (oiiotool's): keep the
                        normals under a --height for --preview
  -d TYPE               pixel type for the following -o: float (default),
                        half, uint16, uint8; integer files store heights
                        as data = (value - 0.5) * scale (scale printed and
                        stored), --normals as (v + 1)/2, --tessellation
                        levels as the code itself
  --compression NAME    file compression for the following -o, by OIIO's
                        names (zip, piz, none...); default none for float
                        EXR (float heights barely compress), else the
                        format's own
)") + operations_help() + R"(Options:
  --report FILE.json    write a JSON report, {"height": {...}, "correct": {...}}:
                        for --height what it chose and the round trip
                        (angular error mean/p95/max in degrees between the
                        input normals and the height's, residual share); for
                        --correct energy, iterations, anisotropy and area
                        ratio before/after; times. Written when the job ends
  --device DEV          auto (default: $RELIEF_DEVICE if set, else the best
                        device: a hardware GPU, then a CPU, then others,
                        simulators last; fp64 and more memory first), gpu,
                        cpu, or PLATFORM:DEVICE as --list-devices numbers them
  --list-devices        list the OpenCL devices and exit
  --batch JOBS.txt      run the file's jobs in this process, one relief
                        command line per line (shell-like quoting, no
                        expansion; blank lines and # comments skipped); they
                        share the device and its compiled kernels. A failed
                        job is reported and the others go on (exit 1 at the
                        end); -v and --device apply to every job
  --shard I/N           with --batch: only the jobs whose index (from 0, in
                        file order) is I modulo N, so N processes share a file
  --log FILE.jsonl      append one JSON object per job: job, line, args,
                        inputs, outputs, status (ok|skipped|failed), seconds,
                        message; whole lines, so batches may share a log
  --update              make-like: skip a job whose outputs all exist and
                        record the digest it would write (relief:digest, a
                        hash of its input files' bytes, every operation and
                        modifier, and relief's kernels); only headers are read
  --dry-run             list the jobs as --log lines on stdout (status
                        pending, or skipped where --update would skip), run none
  --frames A-B[,C-D...] run once per frame: in every file name # alone is the
                        frame number in 4 digits, a run of # or @ one digit
                        each (@@@ = 3 digits), %04d as printf; %# and %@ are
                        a literal # and @; folder names are kept as they are
Names: <UDIM> in an argument runs once per UDIM tile (1001-1999) that exists
for the first input file name holding it, e.g.
  relief 'in/n.<UDIM>.png' --height -o 'out/h.<UDIM>.exr'
Such runs, and --batch, share one device context and report per job.
Files: a run that would write over a file it reads (or write one file twice)
is refused before any work; an image over its own input is allowed. Outputs
are written to a hidden temporary file and renamed when whole; SIGTERM and
SIGINT remove it (exit 128+signal).
  -v                    say what was chosen (device, convention), progress,
                        times, and the image libraries' own diagnostics
  --help, --version
Environment:
  RELIEF_DEVICE_MAX_ALLOC=BYTES  the largest device buffer to allocate (default
                        and upper bound: the device's own limit); larger
                        needs are refused with the numbers
  RELIEF_MEMORY_LIMIT=SIZE  the most memory a map may need (bytes, or with
                        K, M, G, T); maps and heights that need more, or more
                        than the machine or device has, are refused first
  RELIEF_CACHE_DIR=DIR  where compiled kernels are kept between runs (default
                        $XDG_CACHE_HOME/relief or ~/.cache/relief; off: none)
  RELIEF_DEVICE=DEV     what --device auto means (gpu, cpu, PLATFORM:DEVICE)
  RELIEF_FP64=auto|on|off  double accumulations where the device has fp64
                        (auto), required (on), or the float paths (off)
  RELIEF_MAX_WORK_GROUP_SIZE=N, RELIEF_LOCAL_MEM_SIZE=SIZE  lower the device's
                        launch limits (to run as a smaller GPU would)
Examples:
  relief normal.png --height -o height.exr
  relief height.png --correct:scale=0.05:nodes=center -o offsets.exr
  relief albedo.png height.png --correct:scale=0.05 -o offsets.exr --bake -o albedo_fixed.png
  relief normal.png --height:normal=directx:rays=16:radius=32:boundary=clip -o height.exr
  relief normal.png --dup --height -o h.exr --report r.json --preview -o sheet.png
  relief h.exr --mesh:patch=32:error=0.5:out=h.glb --tessellation:patch=32 -o levels.exr
  relief h.exr --normals:normal=directx -d uint8 -o normal_again.png
  relief 'in/n.<UDIM>.png' --height -o 'out/h.<UDIM>.exr' --update
  relief --batch jobs.txt --shard 0/4 --update --log task0.jsonl
  relief-slurm submit jobs.txt --tasks 4   (a Slurm job array; relief-slurm --help)
)";
    return text;
}

namespace {

Step make_step(Step::Kind kind, const std::string& text, const std::string& path = "")
{
    Step s{};
    s.kind = kind;
    s.text = text;
    s.path = path;
    return s;
}

// --NAME[:MODS] of an operation in the table.
Step parse_operation(const std::string& arg, const std::string& name)
{
    Step s = make_step(Step::Kind::Operation, arg);
    const std::size_t colon = arg.find(':');
    const std::string mods = colon == std::string::npos ? std::string() : arg.substr(colon + 1);
    if (!parse_modifiers(s, name, mods))
        throw UsageError(arg + ": " + geterror());
    return s;
}

// The path of a text output (--report, --log): not a folder, in one that exists.
std::string text_output(const std::string& option, const std::string& path)
{
    const fs::path folder = fs::path(path).parent_path();
    std::error_code ec;
    if (path.empty() || fs::is_directory(path, ec) ||
        !fs::is_directory(folder.empty() ? fs::path(".") : folder, ec))
        throw UsageError(option + " " + path + ": not a writable file path (its folder must exist)");
    if (const std::string why = relief::output_name_problem(path); !why.empty())
        throw UsageError(option + " " + why);
    return path;
}

OIIO::TypeDesc parse_format(const std::string& t)
{
    if (t == "float")
        return OIIO::TypeDesc::FLOAT;
    if (t == "half")
        return OIIO::TypeDesc::HALF;
    if (t == "uint16")
        return OIIO::TypeDesc::UINT16;
    if (t == "uint8")
        return OIIO::TypeDesc::UINT8;
    throw UsageError("-d " + t + ": unknown type (float, half, uint16, uint8)");
}

} // namespace

Program parse_command_line(const std::vector<std::string>& args, bool check_inputs)
{
    Program prog;
    OIIO::TypeDesc format = OIIO::TypeDesc::FLOAT;
    bool format_given = false;
    std::string compression;
    bool shard_given = false;
    int depth = 0;  // stack depth as the program will run
    auto need = [&](const std::string& arg, int n) {
        if (depth < n)
            throw UsageError(arg + " needs " + std::to_string(n) + " image(s) on the stack, has " +
                             std::to_string(depth) + " (give the input file before it)");
    };
    auto value_of = [&](std::size_t& i) -> const std::string& {
        if (i + 1 >= args.size())
            throw UsageError(args[i] + " needs a value");
        return args[++i];
    };

    for (std::size_t i = 0; i < args.size(); ++i) {
        const std::string& a = args[i];
        const std::string cmd = a.substr(0, a.find(':'));
        if (a == "--help" || a == "-h") {
            prog.help = true;
        } else if (a == "--version") {
            prog.version = true;
        } else if (a == "-v") {
            prog.verbose = true;
        } else if (a == "--list-devices") {
            prog.list_devices = true;
        } else if (a == "--update") {
            prog.update = true;
        } else if (a == "--dry-run") {
            prog.dry_run = true;
        } else if (a == "--report") {
            prog.report = text_output(a, value_of(i));
        } else if (a == "--batch") {
            prog.batch = value_of(i);
            if (const std::string why = relief::input_file_problem(prog.batch);
                !why.empty() && why != "the file is empty")
                throw UsageError("--batch " + prog.batch + ": " + why);
        } else if (a == "--log") {
            prog.log = text_output(a, value_of(i));
        } else if (a == "--shard") {
            std::tie(prog.shard_index, prog.shard_count) = parse_shard(value_of(i));
            shard_given = true;
        } else if (a == "--device") {
            prog.device = value_of(i);
        } else if (a == "-d") {
            format = parse_format(value_of(i));
            format_given = true;
        } else if (a == "--compression") {
            compression = value_of(i);
            if (compression.empty())
                throw UsageError("--compression needs a name (e.g. zip, piz, none)");
        } else if (a == "--dup") {
            need(a, 1);
            prog.steps.push_back(make_step(Step::Kind::Dup, a));
            ++depth;
        } else if (a == "-o") {
            const std::string& path = value_of(i);
            need(a, 1);
            if (!check_output_path(path))
                throw UsageError("-o " + path + ": " + geterror());
            Step w = make_step(Step::Kind::Write, "-o " + path, path);
            w.format = format;
            w.format_given = format_given;
            w.compression = compression;
            prog.steps.push_back(w);
        } else if (cmd.rfind("--", 0) == 0 && find_operation(cmd.substr(2))) {
            const OperationInfo& op = *find_operation(cmd.substr(2));
            need(cmd, int(op.inputs.size()));
            prog.steps.push_back(parse_operation(a, op.name));
            depth += int(op.outputs.size()) - int(op.inputs.size());
        } else if (!a.empty() && a[0] == '-' && a != "-") {
            throw UsageError("unknown option '" + a + "' (see relief --help)");
        } else {
            // Empty files are the read's to refuse, with the other damage.
            if (const std::string why = check_inputs ? relief::input_file_problem(a) : std::string();
                !why.empty() && why != "the file is empty")
                throw UsageError("cannot read '" + a + "': " + why);
            prog.steps.push_back(make_step(Step::Kind::Read, a, a));
            ++depth;
        }
    }
    if (!prog.batch.empty() && !prog.steps.empty())
        throw UsageError("--batch " + prog.batch +
                         " runs the file's jobs: give the images and operations there, not beside it");
    if (shard_given && prog.batch.empty())
        throw UsageError("--shard takes a share of --batch's jobs; give --batch JOBS.txt");
    if (!prog.batch.empty() && !prog.report.empty())
        throw UsageError("--report names one file: give it in the job's line of the --batch file");
    // The report holds one object per reporting operation (OperationInfo::
    // report), keyed by its name.
    if (!prog.report.empty()) {
        std::string names, counts;
        int total = 0, most = 0;
        for (const OperationInfo& op : operations()) {
            if (op.report.empty())
                continue;
            int n = 0;
            for (const Step& s : prog.steps)
                n += s.kind == Step::Kind::Operation && s.operation == op.name;
            total += n;
            most = std::max(most, n);
            names += (names.empty() ? "--" : " or --") + op.name;
            counts += (counts.empty() ? "" : " and ") + std::to_string(n) + " --" + op.name;
        }
        if (total == 0 || most > 1)
            throw UsageError("--report needs one " + names + ", at most one of each; there are " + counts);
    }
    for (Step& s : prog.steps) {
        s.correct.exec.device = prog.device;
        s.bake.exec.device = prog.device;
        s.slopes.exec.device = prog.device;
        s.height.exec.device = prog.device;
        s.normals.exec.device = prog.device;
        s.tessellation.exec.device = prog.device;
    }
    return prog;
}

std::pair<int, int> parse_shard(const std::string& text)
{
    const std::size_t slash = text.find('/');
    int i = -1, n = 0;
    const char* end = text.data() + text.size();
    const bool ok = slash != std::string::npos &&
                    std::from_chars(text.data(), text.data() + slash, i).ptr == text.data() + slash &&
                    slash + 1 < text.size() &&
                    std::from_chars(text.data() + slash + 1, end, n).ptr == end;
    if (!ok || n < 1 || i < 0 || i >= n)
        throw UsageError("--shard " + text + ": write I/N with 0 <= I < N (e.g. 0/4)");
    return {i, n};
}

} // namespace relief::cli
