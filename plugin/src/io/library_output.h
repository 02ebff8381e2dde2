// SPDX-License-Identifier: Apache-2.0
#pragma once
// The image libraries relief calls (OpenImageIO, and libpng, libtiff, ...
// under it) print diagnostics of their own to stderr: "libpng error: ...",
// "OIIO DEBUG: ...". relief reports failures itself, once, in its own words,
// and a library must not write to its host's stderr. So every call into
// them runs inside a LibraryOutput: while one lives, file descriptor 2 is a
// temporary file, and what lands there is passed on, a line at a time, as
// Severity::Debug messages to this thread's sink (the running operation's
// on_message), else to the handler set_library_messages() installed, else
// nowhere.
//
// Descriptor 2 is the process's: while a capture lives, anything another
// thread writes to stderr is captured too (and passed on with it). Captures
// on several threads overlap: the first redirects, the last restores and
// passes on everything.
#include <functional>
#include <string>

#include "relief/options.h"

namespace relief::detail {

using MessageSink = std::function<void(Severity, const std::string&)>;

class LibraryOutput {
public:
    LibraryOutput();
    ~LibraryOutput();
    LibraryOutput(const LibraryOutput&) = delete;
    LibraryOutput& operator=(const LibraryOutput&) = delete;
};

// While it lives, `sink` receives this thread's captured library output.
class LibraryOutputSink {
public:
    // (`sink` is copied: it may be a temporary.)
    explicit LibraryOutputSink(MessageSink sink);
    ~LibraryOutputSink();
    LibraryOutputSink(const LibraryOutputSink&) = delete;
    LibraryOutputSink& operator=(const LibraryOutputSink&) = delete;

private:
    MessageSink sink_;
    const MessageSink* previous_;
};

}  // namespace relief::detail
