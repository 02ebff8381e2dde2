// relief: the command line. Reads arguments left to right over a stack of
// images (oiiotool style); see `relief --help`.
#include <OpenImageIO/imagebuf.h>

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include "command_line.h"
#include "text_file.h"
#include "relief/relief.h"

namespace {

using relief::Severity;
using relief::cli::Program;
using relief::cli::Step;

struct RuntimeError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// While it lives (unless verbose), the image libraries' own diagnostics on
// stderr ("libpng error: ...", "OIIO DEBUG: ...") go to /dev/null: relief
// reports the failure itself, once. Reads and writes run on this thread.
class QuietLibraries {
public:
    explicit QuietLibraries(bool verbose)
    {
        if (verbose)
            return;
        std::fflush(stderr);
        saved_ = dup(2);
        const int null = open("/dev/null", O_WRONLY | O_CLOEXEC);
        if (saved_ >= 0 && null >= 0)
            dup2(null, 2);
        if (null >= 0)
            close(null);
    }
    ~QuietLibraries()
    {
        if (saved_ < 0)
            return;
        std::fflush(stderr);
        dup2(saved_, 2);
        close(saved_);
    }
    QuietLibraries(const QuietLibraries&) = delete;
    QuietLibraries& operator=(const QuietLibraries&) = delete;

private:
    int saved_ = -1;
};

class Runner {
public:
    explicit Runner(const Program& prog) : prog_(prog) {}

    void run()
    {
        for (const Step& s : prog_.steps) {
            auto t0 = std::chrono::steady_clock::now();
            run_step(s);
            if (prog_.verbose && s.kind != Step::Kind::Read) {
                double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
                std::fprintf(stderr, "relief: %s: %.3f s\n", s.text.c_str(), sec);
            }
        }
    }

private:
    void message(Severity s, const std::string& msg) const
    {
        if (s == Severity::Warning)
            std::fprintf(stderr, "relief: warning: %s\n", msg.c_str());
        else if (s == Severity::Notice || prog_.verbose)
            std::fprintf(stderr, "relief: %s\n", msg.c_str());
    }

    relief::Execution execution(const Step& s) const
    {
        relief::Execution e;
        e.device = prog_.device;
        e.on_message = [this](Severity sev, const std::string& m) { message(sev, m); };
        if (prog_.verbose) {
            auto next = std::make_shared<int>(10);
            std::string name = s.text.substr(0, s.text.find(':'));
            e.on_progress = [name, next](double f) {
                while (f * 100.0 >= *next && *next <= 100) {
                    std::fprintf(stderr, "relief: %s: %d%%\n", name.c_str(), *next);
                    *next += 10;
                }
            };
        }
        return e;
    }

    bool read(OIIO::ImageBuf& img, const std::string& path) const
    {
        QuietLibraries quiet(prog_.verbose);
        return relief::read_image(img, path);
    }

    OIIO::ImageBuf pop()
    {
        OIIO::ImageBuf top = std::move(stack_.back());
        stack_.pop_back();
        return top;
    }

    void run_step(const Step& s)
    {
        switch (s.kind) {
        case Step::Kind::Read: {
            OIIO::ImageBuf img;
            if (!read(img, s.path))
                throw RuntimeError(relief::geterror());
            if (prog_.verbose) {
                const auto& spec = img.spec();
                std::fprintf(stderr, "relief: read %s: %dx%d, %d channel(s), %s\n", s.path.c_str(),
                             spec.width, spec.height, spec.nchannels, img.nativespec().format.c_str());
            }
            stack_.push_back(std::move(img));
            break;
        }
        case Step::Kind::Operation: {
            const relief::OperationInfo& op = *relief::find_operation(s.operation);
            relief::OperationCall call = s;
            // Mask and fixation files are read here, quietly like every read.
            OIIO::ImageBuf mask, fix;
            if (!s.mask_file.empty()) {
                if (!read(mask, s.mask_file))
                    throw RuntimeError("mask: " + relief::geterror());
                call.height.mask = &mask;
            }
            if (!s.fix_file.empty()) {
                if (!read(fix, s.fix_file))
                    throw RuntimeError("fix: " + relief::geterror());
                call.correct.fix_mask = &fix;
            }
            relief::CorrectReport report;
            call.correct.report = &report;
            if (prog_.verbose && s.operation == "height")
                message(Severity::Info, "height: " + relief::describe(call.height));
            // The inputs are the top of the stack, the first input deepest.
            std::vector<OIIO::ImageBuf> in(op.inputs.size());
            for (std::size_t i = in.size(); i-- > 0;)
                in[i] = pop();
            std::vector<const OIIO::ImageBuf*> inputs;
            for (const OIIO::ImageBuf& b : in)
                inputs.push_back(&b);
            OIIO::ImageBuf out;
            if (!relief::run_operation(out, call, inputs, execution(s)))
                throw RuntimeError(relief::geterror());
            if (s.operation == "correct" && !prog_.report.empty())
                relief::cli::write_text_atomically(prog_.report, report.to_json(), "the report");
            stack_.push_back(std::move(out));
            break;
        }
        case Step::Kind::Write: {
            relief::WriteOptions w;
            w.format = s.format;
            const OIIO::ImageBuf& top = stack_.back();
            // Without -d a baked texture keeps its file's pixel type.
            const std::string native = top.spec().get_string_attribute("relief:native_format");
            if (!s.format_given && !native.empty())
                w.format = OIIO::TypeDesc(native);
            if (w.format == OIIO::TypeDesc::HALF && top.spec().get_string_attribute("relief:method") == "correct" &&
                std::max(top.spec().width, top.spec().height) > 2048)
                std::fprintf(stderr, "relief: warning: %s: half offsets above 2048 texels are coarser than 1/8 texel; prefer float\n",
                             s.path.c_str());
            w.compression = s.compression;
            // The integer mapping is needed to read the file back: always say it.
            w.on_message = [](Severity, const std::string& m) {
                std::fprintf(stderr, "relief: %s\n", m.c_str());
            };
            if (!relief::write_image(stack_.back(), s.path, w))
                throw RuntimeError(relief::geterror());
            if (prog_.verbose)
                std::fprintf(stderr, "relief: wrote %s\n", s.path.c_str());
            break;
        }
        }
    }

    const Program& prog_;
    std::vector<OIIO::ImageBuf> stack_;
};

int list_devices()
{
    auto devices = relief::list_devices();
    if (devices.empty())
        throw RuntimeError(relief::geterror());
    for (const auto& d : devices)
        std::printf("%s  %s / %s%s%s\n", d.id.c_str(), d.platform.c_str(), d.name.c_str(),
                    d.is_gpu ? "  [GPU]" : "", d.has_fp64 ? "  fp64" : "");
    return 0;
}

} // namespace

int main(int argc, char** argv)
{
    std::vector<std::string> args(argv + 1, argv + argc);
    Program prog;
    try {
        prog = relief::cli::parse_command_line(args);
    } catch (const relief::cli::UsageError& e) {
        std::fprintf(stderr, "relief: error: %s\n", e.what());
        return 2;
    }
    if (prog.help) {
        std::fputs(relief::cli::usage_text().c_str(), stdout);
        return 0;
    }
    if (prog.version) {
        std::printf("relief %s\n", relief::version());
        return 0;
    }
    try {
        if (prog.list_devices)
            return list_devices();
        if (prog.steps.empty()) {
            std::fputs(relief::cli::usage_text().c_str(), stderr);
            return 2;
        }
        Runner(prog).run();
    } catch (const std::exception& e) {
        std::fprintf(stderr, "relief: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
