// SPDX-License-Identifier: Apache-2.0
#include "read_ahead.h"

#include <chrono>
#include <utility>

#include "console.h"
#include "relief/relief.h"

namespace relief::cli {

ReadAhead::~ReadAhead()
{
    if (done_.valid())
        done_.wait();
}

void ReadAhead::start(std::vector<std::string> paths)
{
    reads_.clear();
    for (std::string& p : paths)
        reads_.push_back({std::move(p), {}, false, false, {}, {}});
    done_ = std::async(std::launch::async, [this] {
        const auto t0 = std::chrono::steady_clock::now();
        for (Read& r : reads_) {
            // What the read says (the image libraries' lines, with -v)
            // comes out when its job takes the image.
            HeldMessages hold(r.messages);
            r.ok = relief::read_image(r.image, r.path);
            if (!r.ok)
                r.error = relief::geterror();
        }
        read_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    });
}

void ReadAhead::wait()
{
    if (!done_.valid())
        return;
    const auto t0 = std::chrono::steady_clock::now();
    done_.get();
    wait_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

bool ReadAhead::take(const std::string& path, OIIO::ImageBuf& image, bool& ok, std::string& error,
                     std::string& messages)
{
    for (Read& r : reads_) {
        if (r.path != path || r.taken)
            continue;
        wait();
        r.taken = true;
        image = std::move(r.image);
        ok = r.ok;
        error = std::move(r.error);
        messages = std::move(r.messages);
        return true;
    }
    return false;
}

}  // namespace relief::cli
