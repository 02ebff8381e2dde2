// SPDX-License-Identifier: Apache-2.0
#pragma once
// A batch's next job's images, read and decoded on another thread while
// the device works on the job before it (run_jobs). The job takes them at
// its read steps; a read that failed fails there, in that job, with the
// message it would have had, so one job's missing file never touches
// another's run.
#include <OpenImageIO/imagebuf.h>

#include <future>
#include <string>
#include <vector>

namespace relief::cli {

class ReadAhead {
public:
    ReadAhead() = default;
    ReadAhead(const ReadAhead&) = delete;
    ReadAhead& operator=(const ReadAhead&) = delete;
    ~ReadAhead();

    // Starts reading `paths`, one after another, on one thread.
    void start(std::vector<std::string> paths);

    // The image of `path` read ahead (waiting for the reads to end), with
    // whether it was read (else `error`) and the messages said meanwhile;
    // false when `path` was not read ahead or was taken already.
    bool take(const std::string& path, OIIO::ImageBuf& image, bool& ok, std::string& error,
              std::string& messages);

    // Seconds the reads took on their thread, and seconds take() waited for them.
    // (Both wait for the reads to end.)
    double read_seconds()
    {
        wait();
        return read_seconds_;
    }
    double wait_seconds()
    {
        wait();
        return wait_seconds_;
    }

private:
    struct Read {
        std::string path;
        OIIO::ImageBuf image;
        bool ok = false, taken = false;
        std::string error, messages;
    };
    void wait();
    std::vector<Read> reads_;
    std::future<void> done_;
    double read_seconds_ = 0.0, wait_seconds_ = 0.0;
};

}  // namespace relief::cli
