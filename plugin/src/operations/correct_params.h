// SPDX-License-Identifier: Apache-2.0
#pragma once
// relief::correct's one translation between the public options and report
// (relief/correct.h) and the host's solver (host/correct/correct_stage.h):
// the choices and the report are the same types on both sides
// (relief/correct_types.h); what is translated here is what the options
// leave to the map (the scale, the boundary, the fixation weights).
#include <OpenImageIO/imagebuf.h>

#include <string>
#include <vector>

#include "correct/correct_stage.h"
#include "relief/correct.h"

namespace relief::detail {

// What a correction runs with.
struct CorrectCall {
    host::CorrectParams base;  // without fixation weights (params() adds them)
    std::vector<float> fix;    // per texel; empty: no fixation
    std::string boundary;      // "periodic", "fixed" or x's,y's ("periodic,fixed"), as chosen
    // The host's parameters, pointing at `fix`.
    host::CorrectParams params() const
    {
        host::CorrectParams p = base;
        p.fix_weights = fix.empty() ? nullptr : fix.data();
        return p;
    }
};

// The call `options` make on `height`, whose region is `heights` (w x h):
// scale=auto from relief's own heights (else an error asking for a scale),
// boundary=auto by each axis's seam test (said as a notice), the fixation
// weights from the mask image or the tent over the height.
CorrectCall correct_call(const OIIO::ImageBuf& height, const std::vector<float>& heights, int w, int h,
                         const CorrectOptions& options);

// The public report of what the host did.
CorrectReport correct_report(const host::CorrectReport& done, const CorrectCall& call, int w, int h);

// relief:parameters: the modifiers that repeat the call.
std::string correct_parameters(const CorrectCall& call, const CorrectOptions& options);

}  // namespace relief::detail
