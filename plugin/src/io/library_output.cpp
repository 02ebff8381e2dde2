// SPDX-License-Identifier: Apache-2.0
#include "library_output.h"

#include <fcntl.h>
#include <unistd.h>

#include <cstdio>
#include <mutex>
#include <string>

#include "relief/imageio.h"

namespace relief::detail {

namespace {

std::mutex state_mutex;
int active = 0;         // LibraryOutputs alive, all threads
int saved_stderr = -1;  // the host's descriptor 2 while one is
int capture = -1;       // the temporary file in its place
MessageSink handler;    // set_library_messages()
thread_local const MessageSink* thread_sink = nullptr;

void pass_on(const std::string& text)
{
    const MessageSink* sink = thread_sink && *thread_sink ? thread_sink : (handler ? &handler : nullptr);
    if (!sink)
        return;
    std::size_t pos = 0;
    while (pos < text.size()) {
        std::size_t end = text.find('\n', pos);
        if (end == std::string::npos)
            end = text.size();
        if (end > pos)
            (*sink)(Severity::Debug, text.substr(pos, end - pos));
        pos = end + 1;
    }
}

}  // namespace

LibraryOutput::LibraryOutput()
{
    const std::lock_guard<std::mutex> lock(state_mutex);
    if (active++ > 0 || saved_stderr >= 0)
        return;
    std::fflush(stderr);
    std::FILE* file = std::tmpfile();
    if (!file)
        return;  // nothing captured: the libraries print as they would
    capture = dup(fileno(file));
    std::fclose(file);
    saved_stderr = capture >= 0 ? fcntl(2, F_DUPFD_CLOEXEC, 3) : -1;
    if (saved_stderr < 0 || dup2(capture, 2) < 0) {
        if (saved_stderr >= 0)
            close(saved_stderr);
        if (capture >= 0)
            close(capture);
        saved_stderr = capture = -1;
    }
}

LibraryOutput::~LibraryOutput()
{
    std::string text;
    {
        const std::lock_guard<std::mutex> lock(state_mutex);
        if (--active > 0 || saved_stderr < 0)
            return;
        std::fflush(stderr);
        dup2(saved_stderr, 2);
        close(saved_stderr);
        saved_stderr = -1;
        char buffer[4096];
        off_t at = 0;
        for (ssize_t n; (n = pread(capture, buffer, sizeof buffer, at)) > 0; at += n)
            text.append(buffer, std::size_t(n));
        close(capture);
        capture = -1;
    }
    try {
        pass_on(text);
    } catch (...) {  // a sink that throws must not end the program here
    }
}

LibraryOutputSink::LibraryOutputSink(MessageSink sink) : sink_(std::move(sink)), previous_(thread_sink)
{
    thread_sink = &sink_;
}

LibraryOutputSink::~LibraryOutputSink()
{
    thread_sink = previous_;
}

}  // namespace relief::detail

namespace relief {

void set_library_messages(std::function<void(Severity, const std::string&)> handler)
{
    const std::lock_guard<std::mutex> lock(detail::state_mutex);
    detail::handler = std::move(handler);
}

}  // namespace relief
