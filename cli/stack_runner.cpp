// SPDX-License-Identifier: Apache-2.0
// The stack runner: one command line's steps over a stack of images.
#include "stack_runner.h"

#include <OpenImageIO/imagebuf.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <future>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "console.h"
#include "job_digest.h"
#include "json_text.h"
#include "text_file.h"
#include "relief/relief.h"

namespace relief::cli {

namespace {

using relief::Severity;

class StackRunner {
public:
    // `first_output`: the number of the first file it writes among its
    // job's (a tile set's later tiles follow the earlier ones').
    StackRunner(const Program& prog, std::string digest, int first_output = 0, ReadAhead* ahead = nullptr)
        : prog_(prog), digest_(std::move(digest)), outputs_(first_output), ahead_reads_(ahead)
    {
    }

    // Runs the steps before `tail`; returns the rest (steps from `tail`
    // on, then finish()), to be run later if `tail` is not the end.
    std::function<void()> run(std::size_t tail)
    {
        const double prepared = relief::setup_times().prepared;
        prepare_ahead();
        for (std::size_t k = 0; k < tail; ++k)
            timed(prog_.steps[k], [&] { run_step(prog_.steps[k]); });
        return [this, tail, prepared] {
            for (std::size_t k = tail; k < prog_.steps.size(); ++k)
                timed(prog_.steps[k], [&] { run_step(prog_.steps[k]); });
            finish(prepared);
        };
    }

    // A step, and with -v its time: `work` runs it.
    template <class Work>
    void timed(const Step& s, Work&& work)
    {
        const auto t0 = std::chrono::steady_clock::now();
        const relief::SetupTimes before = relief::setup_times();
        work();
        if (!prog_.verbose)
            return;
        const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        const relief::SetupTimes after = relief::setup_times();
        const double device = after.device - before.device, programs = after.programs - before.programs,
                     plans = after.plans - before.plans;
        if (s.kind == Step::Kind::Operation)
            say("relief: %s%s: %.3f s (device set-up %.3f, kernel builds %.3f, FFT plans %.3f, "
                "the map's own work %.3f)\n",
                prog_.label.c_str(), s.text.c_str(), sec, device, programs, plans,
                sec - device - programs - plans);
        else
            say("relief: %s%s: %.3f s\n", prog_.label.c_str(),
                s.kind == Step::Kind::Read ? ("read " + s.path).c_str() : s.text.c_str(), sec);
    }

    // An operation's call as this program runs it: its report to `report`,
    // its written files counted. (The files it reads, mask= and fix=, the
    // table reads as it runs the call.)
    relief::OperationCall prepare_call(const Step& s, std::string& report)
    {
        const relief::OperationInfo& op = *relief::find_operation(s.operation);
        relief::OperationCall call = s;
        // A file it writes (mesh's out=) records its digest, as -o images do.
        // (Numbered as output_files() lists them: one file per operation today.)
        const std::size_t written = relief::files_written(s).size();
        if (written > 0)
            call.file_digest = output_digest(digest_, outputs_);
        outputs_ += int(written);
        // A height's round trip costs a pass: only when it is reported or shown.
        if (!op.report.empty() && (!prog_.report.empty() || prog_.verbose))
            call.report_json = &report;
        if (const std::string choices = prog_.verbose ? relief::describe(call) : ""; !choices.empty())
            message(Severity::Info, op.name + ": " + choices);
        return call;
    }

    // The result of an operation (prepare_call's) pushed, its report kept.
    void push_result(OIIO::ImageBuf&& out, const relief::OperationCall& call, const std::string& report)
    {
        if (call.report_json)
            report_.emplace_back(relief::find_operation(call.operation)->report, report);
        stack_.push_back(std::move(out));
    }

    OIIO::ImageBuf pop()
    {
        OIIO::ImageBuf top = std::move(stack_.back());
        stack_.pop_back();
        return top;
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
                if (f >= 1.0 && *next == 10)
                    return;  // an operation without steps of its own: done, no percentages
                while (f * 100.0 >= *next && *next <= 100) {
                    say("relief: %s: %d%%\n", name.c_str(), *next);
                    *next += 10;
                }
            };
        }
        return e;
    }

    void run_step(const Step& s)
    {
        switch (s.kind) {
        case Step::Kind::Read: {
            OIIO::ImageBuf img;
            bool ok = false;
            std::string error, messages;
            if (ahead_reads_ && ahead_reads_->take(s.path, img, ok, error, messages)) {
                say_text(messages);
                if (!ok)
                    throw RunError(error);
            } else if (!read(img, s.path)) {
                throw RunError(relief::geterror());
            }
            if (prog_.verbose) {
                const auto& spec = img.spec();
                say("relief: read %s: %dx%d, %d channel(s), %s\n", s.path.c_str(), spec.width, spec.height,
                    spec.nchannels, img.nativespec().format.c_str());
            }
            stack_.push_back(std::move(img));
            break;
        }
        case Step::Kind::Operation: {
            const relief::OperationInfo& op = *relief::find_operation(s.operation);
            std::string report;
            const relief::OperationCall call = prepare_call(s, report);
            // The inputs are the top of the stack, the first input deepest.
            std::vector<OIIO::ImageBuf> in(op.inputs.size());
            for (std::size_t i = in.size(); i-- > 0;)
                in[i] = pop();
            std::vector<const OIIO::ImageBuf*> inputs;
            for (const OIIO::ImageBuf& b : in)
                inputs.push_back(&b);
            OIIO::ImageBuf out;
            if (!relief::run_operation(out, call, inputs, execution(s)))
                throw RunError(relief::geterror());
            push_result(std::move(out), call, report);
            break;
        }
        case Step::Kind::Dup: {
            OIIO::ImageBuf copy;
            if (!copy.copy(stack_.back()))
                throw RunError("--dup: " + copy.geterror());
            stack_.push_back(std::move(copy));
            break;
        }
        case Step::Kind::Write: write(s); break;
        }
    }

    // The --report file and, with -v, what was set up ahead.
    void finish(double prepared)
    {
        if (!prog_.report.empty()) {
            // One object per reporting operation, in the order they ran.
            Json json = Json::object();
            for (const auto& [key, object] : report_)
                json[key] = Json::parse(object);
            write_text_atomically(prog_.report, json_text(json, 2) + "\n", "the report");
        }
        if (prog_.verbose && ahead_.valid()) {
            ahead_.wait();
            say("relief: %sset up ahead, beside the read: %.3f s\n", prog_.label.c_str(),
                relief::setup_times().prepared - prepared);
        }
    }

private:
    // A program that starts by reading a map and taking its Poisson height
    // (the default: relief::sets_up_ahead) sets up the device, kernels and
    // FFT plans for that size on a second thread while the map is read and
    // decoded.
    void prepare_ahead()
    {
        const auto& st = prog_.steps;
        std::size_t first = 1;  // the first operation (a --dup before it changes nothing)
        while (first < st.size() && st[first].kind == Step::Kind::Dup)
            ++first;
        if (first >= st.size() || st[0].kind != Step::Kind::Read || st[first].kind != Step::Kind::Operation ||
            !relief::sets_up_ahead(st[first]))
            return;
        // The size from the header (about a millisecond): a damaged file
        // is the read's to report.
        int width = 0, height = 0;
        if (!relief::image_size(st[0].path, width, height))
            return;
        ahead_ = std::async(std::launch::async, [device = prog_.device, width, height] {
            relief::prepare(device, width, height);
        });
    }

    void message(Severity s, const std::string& msg) const
    {
        if (s == Severity::Warning)
            say("relief: %swarning: %s\n", prog_.label.c_str(), msg.c_str());
        else if (s == Severity::Notice || prog_.verbose)
            say("relief: %s%s\n", prog_.label.c_str(), msg.c_str());
    }

    bool read(OIIO::ImageBuf& img, const std::string& path) const { return relief::read_image(img, path); }

    void write(const Step& s)
    {
        relief::WriteOptions w;
        w.format = s.format;
        const OIIO::ImageBuf& top = stack_.back();
        // Without -d a baked texture keeps its file's pixel type.
        const std::string native = top.spec().get_string_attribute("relief:native_format");
        if (!s.format_given && !native.empty())
            w.format = OIIO::TypeDesc(native);
        // A result that half floats hold only up to a size says so.
        const int half_max = top.spec().get_int_attribute("relief:half_max_texels", 0);
        if (w.format == OIIO::TypeDesc::HALF && half_max > 0 &&
            std::max(top.spec().width, top.spec().height) > half_max)
            say("relief: warning: %s: half values above %d texels are coarser than 1/8 "
                "texel; prefer float\n",
                s.path.c_str(), half_max);
        w.compression = s.compression;
        const std::string digest = output_digest(digest_, outputs_++);
        if (digest.empty())
            stack_.back().specmod().erase_attribute("relief:digest");
        else
            stack_.back().specmod().attribute("relief:digest", digest);
        // The integer mapping is needed to read the file back: always say it.
        w.on_message = [](Severity, const std::string& m) { say("relief: %s\n", m.c_str()); };
        if (!relief::write_image(stack_.back(), s.path, w))
            throw RunError(relief::geterror());
        if (prog_.verbose)
            say("relief: wrote %s\n", s.path.c_str());
    }

    const Program& prog_;
    const std::string digest_;
    // (OperationInfo::report, its JSON object) in the order they ran;
    // --report allows one operation of each report.
    std::vector<std::pair<std::string, std::string>> report_;
    int outputs_ = 0;          // outputs (-o images, --mesh files) written so far
    ReadAhead* ahead_reads_;   // this job's images read ahead, or null
    std::future<void> ahead_;  // prepare_ahead(); its destructor waits for it
    std::vector<OIIO::ImageBuf> stack_;
};

}  // namespace

std::size_t trailing_writes(const std::vector<Step>& steps)
{
    std::size_t k = steps.size();
    while (k > 0 && steps[k - 1].kind == Step::Kind::Write)
        --k;
    return k;
}

DeferredWrites run_steps(const Program& prog, const std::string& digest, const JobOverlap& overlap)
{
    auto runner = std::make_shared<StackRunner>(prog, digest, 0, overlap.ahead);
    const std::size_t tail = overlap.defer_writes ? trailing_writes(prog.steps) : prog.steps.size();
    std::function<void()> rest = runner->run(tail);
    if (tail == prog.steps.size()) {
        rest();
        return {};
    }
    return [runner, rest] { rest(); };
}

DeferredWrites run_tile_steps(const std::vector<Program>& tiles, const std::vector<int>& numbers,
                              const std::string& digest, const JobOverlap& overlap)
{
    // One runner per tile, step by step in lockstep: an operation that
    // joins tiles takes every tile's top at once; every other step runs
    // tile by tile. (The tiles' programs differ only in their file names.)
    auto runners = std::make_shared<std::vector<std::unique_ptr<StackRunner>>>();
    int first_output = 0;
    for (const Program& p : tiles) {
        runners->push_back(std::make_unique<StackRunner>(p, digest, first_output, overlap.ahead));
        first_output += int(output_files(p).size());
    }
    const double prepared = relief::setup_times().prepared;
    const std::vector<Step>& steps = tiles.front().steps;
    const std::size_t tail = overlap.defer_writes ? trailing_writes(steps) : steps.size();
    // The steps from `tail` on, tile by tile, and each tile's report.
    auto rest = [runners, &tiles, tail, prepared] {
        for (std::size_t t = 0; t < runners->size(); ++t) {
            StackRunner& r = *(*runners)[t];
            for (std::size_t k = tail; k < tiles[t].steps.size(); ++k)
                r.timed(tiles[t].steps[k], [&] { r.run_step(tiles[t].steps[k]); });
        }
        for (auto& r : *runners)
            r->finish(prepared);
    };
    auto& rs = *runners;
    for (std::size_t k = 0; k < tail; ++k) {
        const Step& s = steps[k];
        if (s.kind != Step::Kind::Operation || !relief::joins_tiles(s)) {
            for (std::size_t t = 0; t < rs.size(); ++t)
                rs[t]->timed(tiles[t].steps[k], [&] { rs[t]->run_step(tiles[t].steps[k]); });
            continue;
        }
        StackRunner& first = *rs.front();
        first.timed(s, [&] {
            std::vector<OIIO::ImageBuf> in(rs.size()), out;
            std::vector<std::string> report(rs.size());
            std::vector<relief::OperationCall> calls;
            std::vector<const OIIO::ImageBuf*> inputs;
            for (std::size_t t = 0; t < rs.size(); ++t) {
                calls.push_back(rs[t]->prepare_call(tiles[t].steps[k], report[t]));
                in[t] = rs[t]->pop();
                inputs.push_back(&in[t]);
            }
            if (!relief::run_operation_on_tiles(out, calls.front(), numbers, inputs, first.execution(s)))
                throw RunError(relief::geterror());
            for (std::size_t t = 0; t < rs.size(); ++t)
                rs[t]->push_result(std::move(out[t]), calls[t], report.front());
        });
    }
    if (tail == steps.size()) {
        rest();
        return {};
    }
    return rest;
}

}  // namespace relief::cli
