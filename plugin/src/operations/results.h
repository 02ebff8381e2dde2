// SPDX-License-Identifier: Apache-2.0
#pragma once
// What every operation does with its region, its messages, its result and
// its failure (results.cpp).
#include <OpenImageIO/imagebuf.h>

#include <exception>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "callbacks.h"
#include "device/cancel.h"
#include "io/library_output.h"
#include "relief/options.h"
#include "relief/validate.h"
#include "slopes/slope_stage.h"

namespace relief::detail {

// Validates `roi` against `image` (undefined = the whole image).
OIIO::ROI resolve_roi(const OIIO::ImageBuf& image, OIIO::ROI roi);

// While an operation runs: exec.cancel, asked once now and then before
// each kernel (host/device/cancel.h), and exec.on_message, where the image
// libraries' output goes (io/library_output.h).
class OperationScope : host::CancelCheck, LibraryOutputSink {
public:
    explicit OperationScope(const Execution& exec)
        : host::CancelCheck(marked(exec.cancel)), LibraryOutputSink(marked(exec.on_message))
    {
        if (std::string why = reentry_problem(); !why.empty())
            throw std::invalid_argument(std::move(why));
        host::stop_if_cancelled();
    }
};

// Passes one line to exec.on_message, if any.
void say(const Execution& exec, Severity severity, const std::string& message);

// printf-style formatting of one number ("%.3g").
std::string format_double(const char* fmt, double v);

// The float result image of an operation over `roi`: the spec (channel
// names, the method and unit, what the slope stage chose) and the pixels.
void publish_result(OIIO::ImageBuf& dst, OIIO::ROI roi, std::vector<std::string> channels, const char* method,
                    const host::SlopeStats& stats, const float* pixels, const std::string& parameters = "");

// A result image of `roi`'s size and origin with float `channels`, made
// when a stage asks for its memory (host::HeightSink); publish_result(dst,
// ..., std::move(it), ...) then tags it and hands it to dst without a copy.
OIIO::ImageBuf make_result(OIIO::ROI roi, std::vector<std::string> channels);
void publish_result(OIIO::ImageBuf& dst, OIIO::ImageBuf&& result, const char* method,
                    const host::SlopeStats& stats, const std::string& parameters);

// The API's first form (returns the image) from its second (fills `dst`):
// second_form(dst); a failure leaves its error in the image returned.
template <class SecondForm>
OIIO::ImageBuf first_form(SecondForm&& second_form)
{
    OIIO::ImageBuf dst;
    second_form(dst);
    return dst;
}

// dst becomes an image of `spec` (its channels float) holding `pixels`.
void set_result(OIIO::ImageBuf& dst, const OIIO::ImageSpec& spec, const float* pixels);

// Throws std::invalid_argument in validate(options)'s words when `options`
// break a rule: the first thing each operation does.
template <class Options>
void require_valid(const Options& options)
{
    if (std::string problem = validate(options); !problem.empty())
        throw std::invalid_argument(std::move(problem));
}

// Records a failed operation in dst and geterror(); returns false.
bool fail(OIIO::ImageBuf& dst, const char* operation, const std::exception& e);

// The frame of every operation's second form: `body` (which fills dst and
// returns whether it did) runs in an OperationScope of `exec` once
// `options` are valid; an exception becomes fail(dst, operation, e).
template <class Options, class Body>
bool guarded(OIIO::ImageBuf& dst, const char* operation, const Execution& exec, const Options& options,
             Body&& body)
{
    try {
        const OperationScope scope(exec);
        require_valid(options);
        return body();
    } catch (const std::exception& e) {
        return fail(dst, operation, e);
    }
}

}  // namespace relief::detail
