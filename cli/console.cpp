// SPDX-License-Identifier: Apache-2.0
#include "console.h"

#include <fcntl.h>
#include <unistd.h>

#include <cstdarg>
#include <vector>

namespace relief::cli {

namespace {

std::FILE* console_file = nullptr;
thread_local std::string* held = nullptr;

std::FILE* out()
{
    return console_file ? console_file : stderr;
}

}  // namespace

void open_console()
{
    if (console_file)
        return;
    const int fd = fcntl(2, F_DUPFD_CLOEXEC, 3);
    if (fd < 0)
        return;
    console_file = fdopen(fd, "w");
    if (!console_file) {
        close(fd);
        return;
    }
    // Unbuffered, as stderr: a line is out when say() returns (a killed
    // process loses none, and lines from several threads do not mix).
    std::setvbuf(console_file, nullptr, _IONBF, 0);
}

void say(const char* format, ...)
{
    va_list args;
    va_start(args, format);
    va_list again;
    va_copy(again, args);
    const int n = std::vsnprintf(nullptr, 0, format, args);
    va_end(args);
    std::string text;
    if (n > 0) {
        std::vector<char> buffer(std::size_t(n) + 1);
        std::vsnprintf(buffer.data(), buffer.size(), format, again);
        text.assign(buffer.data(), std::size_t(n));
    }
    va_end(again);
    say_text(text);
}

void say_text(const std::string& text)
{
    if (held) {
        *held += text;
        return;
    }
    // One write per text: an unbuffered stream writes a whole fputs at once.
    std::fputs(text.c_str(), out());
}

HeldMessages::HeldMessages(std::string& into) : previous_(held)
{
    held = &into;
}

HeldMessages::~HeldMessages()
{
    held = previous_;
}

}  // namespace relief::cli
