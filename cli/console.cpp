// SPDX-License-Identifier: Apache-2.0
#include "console.h"

#include <fcntl.h>
#include <unistd.h>

#include <OpenImageIO/strutil.h>

#include <cstdarg>

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
    const std::string text = OIIO::Strutil::vsprintf(format, args);
    va_end(args);
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
