// SPDX-License-Identifier: Apache-2.0
#pragma once
// Where the command line's own messages go. The library captures descriptor
// 2 while it calls the image libraries (so that their "libpng error: ..."
// lines never reach the user unasked); in a batch those calls run on other
// threads (reads ahead, writes behind) while this thread reports, and a
// message printed to stderr then would be captured with them. So relief's
// lines go to a duplicate of descriptor 2 taken before any capture.
//
// And in a batch whose jobs overlap, a thread may hold its messages back:
// a job's lines come out together and in job order, as when jobs ran one
// after another.
#include <cstdio>
#include <string>

namespace relief::cli {

// Takes the duplicate of descriptor 2 (call first thing in main; without
// it, messages go to stderr).
void open_console();

// Prints to the console, or into this thread's held text (HeldMessages).
void say(const char* format, ...) __attribute__((format(printf, 1, 2)));

// Prints text as it is (held text let go, a usage text).
void say_text(const std::string& text);

// While it lives, this thread's say() appends to `into` instead.
class HeldMessages {
public:
    explicit HeldMessages(std::string& into);
    ~HeldMessages();
    HeldMessages(const HeldMessages&) = delete;
    HeldMessages& operator=(const HeldMessages&) = delete;

private:
    std::string* previous_;
};

}  // namespace relief::cli
