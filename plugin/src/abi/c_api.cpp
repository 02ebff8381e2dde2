// SPDX-License-Identifier: Apache-2.0
// The C ABI (relief/relief_c.h): the operation table's parser and runner
// behind plain C types. Nothing thrown gets past a function here.
#include "relief/relief_c.h"

#include <OpenImageIO/imagebuf.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <functional>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

#include "callbacks.h"
#include "error_state.h"
#include "relief/errors.h"
#include "relief/operations.h"

namespace {

using OIIO::ImageBuf;
using OIIO::TypeDesc;

thread_local std::string c_last_error;

struct Refused : std::invalid_argument {
    using std::invalid_argument::invalid_argument;
};

// A C caller may store any int in the enum; C++ may not load one outside
// its range (UBSan: "not a valid value for type 'relief_type'"). So its
// bytes are read as the int they are.
TypeDesc type_of(const relief_type& stored)
{
    int t = 0;
    static_assert(sizeof(relief_type) == sizeof(int), "C enums are ints here");
    std::memcpy(&t, &stored, sizeof t);
    switch (t) {
    case RELIEF_UINT8: return TypeDesc::UINT8;
    case RELIEF_UINT16: return TypeDesc::UINT16;
    case RELIEF_HALF: return TypeDesc::HALF;
    case RELIEF_FLOAT: return TypeDesc::FLOAT;
    }
    throw Refused("unknown pixel type " + std::to_string(int(t)) +
                  " (RELIEF_UINT8, RELIEF_UINT16, RELIEF_HALF or RELIEF_FLOAT)");
}

// An input as the command line would hold the same file: the pixels in
// their own type, so integer maps decode as UNORM.
ImageBuf to_imagebuf(const relief_image& in, const relief::ImageSlot& slot, const std::string& op)
{
    const std::string what = op + ": input '" + slot.name + "'";
    const TypeDesc type = type_of(in.type);
    // Before a pixel is copied: a size the kernels cannot index or this
    // machine cannot hold is the caller's to fix (RELIEF_INVALID).
    const std::string problem =
        relief::input_problem(op, slot, in.width, in.height, in.channels, int(type.size()));
    if (!problem.empty())
        throw Refused(problem);
    if (!in.pixels)
        throw Refused(what + " has no pixels (NULL)");
    OIIO::ImageSpec spec(in.width, in.height, in.channels, type);
    ImageBuf buf(spec);
    if (!buf.set_pixels(buf.roi(), type, in.pixels))
        throw std::runtime_error(what + ": " + buf.geterror());
    if (in.metadata) {
        const std::string text = in.metadata;
        std::size_t pos = 0;
        while (pos < text.size()) {
            std::size_t end = text.find('\n', pos);
            if (end == std::string::npos)
                end = text.size();
            const std::string line = text.substr(pos, end - pos);
            const std::size_t eq = line.find('=');
            if (eq != std::string::npos && eq > 0)
                buf.specmod().attribute(line.substr(0, eq), line.substr(eq + 1));
            pos = end + 1;
        }
    }
    return buf;
}

char* copy_text(const std::string& s)
{
    char* p = static_cast<char*>(std::malloc(s.size() + 1));
    if (!p)
        throw std::bad_alloc();
    std::memcpy(p, s.c_str(), s.size() + 1);
    return p;
}

// A run its caller's progress callback stopped.
struct CancelledRun : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// `img` as the caller's floats. A large result (a preview sheet of a 1024^2
// map: 20M values, 0.2 s) is converted in bands of rows, `between` called
// before each: the host's heartbeat, which throws CancelledRun when the
// host has asked to stop (nothing is kept).
void to_c_image(const ImageBuf& img, relief_image* out, const std::function<void()>& between = {})
{
    const OIIO::ImageSpec& spec = img.spec();
    const std::size_t row = std::size_t(spec.width) * spec.nchannels;
    std::unique_ptr<float, decltype(&std::free)> px(
        static_cast<float*>(std::malloc(row * spec.height * sizeof(float))), &std::free);
    if (!px)
        throw std::bad_alloc();
    const int band = int(std::max<std::size_t>(1, (std::size_t(1) << 20) / std::max<std::size_t>(row, 1)));
    for (int y = 0; y < spec.height; y += band) {
        if (between)
            between();
        OIIO::ROI rows = img.roi();
        rows.ybegin = spec.y + y;
        rows.yend = spec.y + std::min(y + band, spec.height);
        if (!img.get_pixels(rows, TypeDesc::FLOAT, px.get() + row * std::size_t(y)))
            throw std::runtime_error("cannot read the result: " + img.geterror());
    }
    std::string meta;
    for (const auto& p : spec.extra_attribs)
        if (p.name().string().rfind("relief:", 0) == 0)
            meta += p.name().string() + "=" + p.get_string() + "\n";
    char* text = copy_text(meta);
    out->width = spec.width;
    out->height = spec.height;
    out->channels = spec.nchannels;
    out->type = RELIEF_FLOAT;
    out->pixels = px.release();
    out->metadata = text;
}

// A C entry point's call: the operation (its name and table entry) and its
// modifiers parsed, or Refused saying why not.
struct ParsedCall {
    relief::OperationCall call;
    std::string name;
    const relief::OperationInfo* info = nullptr;
};

ParsedCall parse_call(const char* operation, const char* modifiers)
{
    if (std::string why = relief::detail::reentry_problem(); !why.empty())
        throw Refused(why);
    if (!operation)
        throw Refused("relief_run: operation is NULL");
    ParsedCall p;
    p.name = operation;
    if (!relief::parse_modifiers(p.call, p.name, modifiers ? modifiers : ""))
        throw Refused(relief::find_operation(p.name) ? p.name + ": " + relief::geterror()
                                                     : relief::geterror());
    p.info = relief::find_operation(p.name);
    return p;
}

// The device a C caller named: NULL or "" is "auto", as relief_run uses.
std::string device_or_auto(const char* device)
{
    return device && *device ? device : "auto";
}

// The caller's images converted for the table's input slots (all of them
// for the first slot when they are the tiles of a UDIM set), and pointers
// to them for run_operation.
struct InputImages {
    std::vector<ImageBuf> images;
    std::vector<const ImageBuf*> pointers;
    InputImages(const relief_image* inputs, int n, const relief::OperationInfo& info, const std::string& op,
                bool tiles)
    {
        images.reserve(std::size_t(n));
        for (int i = 0; i < n; ++i)
            images.push_back(to_imagebuf(inputs[i], info.inputs[tiles ? 0 : std::size_t(i)], op));
        for (const ImageBuf& b : images)
            pointers.push_back(&b);
    }
};

// The host's callbacks as an operation's Execution: messages at their
// severity, progress passed on, and a non-zero answer from progress kept as
// the cancel the operation asks about before each kernel.
class HostCallbacks {
public:
    explicit HostCallbacks(const relief_callbacks* callbacks)
    {
        if (callbacks)
            cb_ = *callbacks;
    }

    relief::Execution execution(const char* device)
    {
        relief::Execution exec;
        exec.device = device_or_auto(device);
        if (cb_.message)
            exec.on_message = [this](relief::Severity s, const std::string& text) { say(severity(s), text); };
        if (cb_.progress) {
            // The operation's 1 is held back until the result is the host's
            // (finish()): converting it may take a while, heartbeat() beats.
            exec.on_progress = [this](double fraction) {
                if (fraction < 1.0)
                    progress(fraction);
            };
            exec.cancel = [this] { return cancelled_; };
        }
        return exec;
    }
    // Reports `fraction` done; false once the host has asked to cancel.
    bool progress(double fraction)
    {
        const relief::detail::InCallback in;
        heard_ = {fraction, std::chrono::steady_clock::now()};
        if (cb_.progress && !cancelled_ && cb_.progress(fraction, cb_.user) != 0)
            cancelled_ = true;
        return !cancelled_;
    }
    // The last fraction again once the heartbeat's interval has passed
    // since the host last heard (as detail::paced does while kernels run);
    // false once it has asked to cancel.
    bool heartbeat()
    {
        if (cb_.progress && std::chrono::steady_clock::now() - heard_.at >= relief::detail::kHeartbeat)
            return progress(heard_.fraction);
        return !cancelled_;
    }
    // The final 1, once the result is the host's: an answer to it cancels
    // nothing.
    void finish()
    {
        if (cb_.progress)
            progress(1.0);
    }
    bool cancelled() const { return cancelled_; }
    void say(relief_severity severity, const std::string& text) const
    {
        const relief::detail::InCallback in;
        if (cb_.message)
            cb_.message(int(severity), text.c_str(), cb_.user);
    }

private:
    static relief_severity severity(relief::Severity s)
    {
        switch (s) {
        case relief::Severity::Debug: return RELIEF_DEBUG;
        case relief::Severity::Info: return RELIEF_INFO;
        case relief::Severity::Notice: return RELIEF_NOTICE;
        case relief::Severity::Warning: return RELIEF_WARNING;
        }
        return RELIEF_INFO;
    }
    relief_callbacks cb_{};
    bool cancelled_ = false;
    struct {
        double fraction = 0.0;
        std::chrono::steady_clock::time_point at = std::chrono::steady_clock::now();
    } heard_;
};

// Runs the body of a C entry point that makes images: RELIEF_OK when it
// returns, RELIEF_INVALID for a refusal, RELIEF_CANCELLED when the host's
// progress callback stopped it, RELIEF_FAILED otherwise, the message left
// for relief_last_error() (and given to the host's message callback, if
// any, as RELIEF_ERROR) and `leave_nothing` run so that no output is half
// made.
template <class Body, class Cleanup>
int run_entry(const char* entry, const HostCallbacks* host, Body body, Cleanup leave_nothing)
{
    c_last_error.clear();
    int status = RELIEF_FAILED;
    try {
        body();
        return RELIEF_OK;
    } catch (const Refused& e) {
        c_last_error = e.what();
        status = RELIEF_INVALID;
    } catch (const CancelledRun& e) {
        c_last_error = e.what();
        status = RELIEF_CANCELLED;
    } catch (const std::exception& e) {
        c_last_error = e.what();
    } catch (...) {
        c_last_error = std::string(entry) + ": unknown failure";
    }
    leave_nothing();
    if (host) {
        // The host hears why; whatever its callback does (it may call relief
        // again, which sets the thread's last error), the outer call's
        // error is what relief_last_error() says after it returns.
        const std::string error = c_last_error;
        host->say(RELIEF_ERROR, error);
        c_last_error = error;
    }
    return status;
}

// Why an operation that returned false failed: the host's cancel, or the
// operation's error.
[[noreturn]] void operation_failed(const HostCallbacks& host, const std::string& op)
{
    const std::string error = relief::geterror();
    if (host.cancelled())
        throw CancelledRun(error.empty() ? op + ": cancelled" : error);
    throw std::runtime_error(error);
}

}  // namespace

extern "C" {

int relief_abi_version(void)
{
    return RELIEF_ABI_VERSION;
}

const char* relief_operations_json(void)
{
    try {
        static const std::string json = relief::operations_json();
        return json.c_str();
    } catch (...) {
        return "{}";
    }
}

int relief_run(const char* operation, const char* modifiers, const relief_image* inputs, int n_inputs,
               relief_image* output)
{
    return relief_run_on("auto", operation, modifiers, inputs, n_inputs, output);
}

int relief_run_on(const char* device, const char* operation, const char* modifiers,
                  const relief_image* inputs, int n_inputs, relief_image* output)
{
    return relief_run_with(device, operation, modifiers, inputs, n_inputs, output, nullptr);
}

int relief_run_with(const char* device, const char* operation, const char* modifiers,
                    const relief_image* inputs, int n_inputs, relief_image* output,
                    const relief_callbacks* callbacks)
{
    HostCallbacks host(callbacks);
    bool delivered = false;  // `output` holds the result (then only the final 1 can fail)
    return run_entry(
        "relief_run", &host,
        [&] {
            if (!output)
                throw Refused("relief_run: output is NULL");
            const auto [call, op, info] = parse_call(operation, modifiers);
            if (const std::string why =
                    relief::call_problem(op, std::size_t(inputs ? std::max(n_inputs, 0) : 0));
                !why.empty())
                throw Refused(why);
            const InputImages in(inputs, n_inputs, *info, op, false);
            // Only now: `output` may be one of the inputs.
            *output = relief_image{};
            ImageBuf result;
            if (!relief::run_operation(result, call, in.pointers, host.execution(device)))
                operation_failed(host, op);
            // (`name`: a lambda may not capture a structured binding in C++17)
            to_c_image(result, output, [&, name = op] {
                if (!host.heartbeat())
                    throw CancelledRun(name + ": cancelled");
            });
            delivered = true;
            host.finish();
        },
        [&] {
            if (output) {
                if (delivered)  // (a C++ host's progress threw at the final 1)
                    relief_image_free(output);
                *output = relief_image{};
            }
        });
}

int relief_run_tiles(const char* device, const char* operation, const char* modifiers, const int* tiles,
                     const relief_image* inputs, int n_tiles, relief_image* outputs)
{
    bool zeroed = false;  // outputs hold nothing of the caller's any more
    return run_entry(
        "relief_run_tiles", nullptr,
        [&] {
            if (!outputs)
                throw Refused("relief_run_tiles: outputs is NULL");
            const auto [call, op, info] = parse_call(operation, modifiers);
            const std::size_t given = n_tiles > 0 ? std::size_t(n_tiles) : 0;
            const std::vector<int> numbers =
                tiles ? std::vector<int>(tiles, tiles + given) : std::vector<int>();
            if (const std::string why = relief::tiles_call_problem(op, numbers, inputs ? given : 0);
                !why.empty())
                throw Refused(why);
            const InputImages in(inputs, n_tiles, *info, op, true);
            // Only now: `outputs` may be the inputs' own array.
            for (int i = 0; i < n_tiles; ++i)
                outputs[i] = relief_image{};
            zeroed = true;
            std::vector<ImageBuf> results;
            relief::Execution exec;
            exec.device = device_or_auto(device);
            if (!relief::run_operation_on_tiles(results, call, numbers, in.pointers, exec))
                throw std::runtime_error(relief::geterror());
            for (int i = 0; i < n_tiles; ++i)
                to_c_image(results[i], &outputs[i]);
        },
        [&] {
            if (outputs)
                for (int i = 0; i < n_tiles; ++i) {
                    if (zeroed)
                        relief_image_free(&outputs[i]);  // (the results made before the failure)
                    outputs[i] = relief_image{};
                }
        });
}

void relief_image_free(relief_image* image)
{
    if (!image)
        return;
    std::free(image->pixels);
    std::free(image->metadata);
    *image = relief_image{};
}

const char* relief_last_error(void)
{
    return c_last_error.c_str();
}

const relief_plugin* relief_plugin_entry(void)
{
    static const relief_plugin plugin = {relief_abi_version, relief_operations_json, relief_run,
                                         relief_image_free,  relief_last_error,      relief_run_with};
    return &plugin;
}

}  // extern "C"
