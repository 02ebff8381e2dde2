// SPDX-License-Identifier: Apache-2.0
#pragma once
// How relief writes files: never in place.
//
// Every output (images, meshes, text) is written into a temporary file in
// the target's folder and renamed over the target only when complete, so a
// failure or a kill leaves the old file (or none) and never half a file.
// The temporary file is created exclusively (O_CREAT|O_EXCL) under a name no
// other process can pick, and that no glob of the target's extension
// matches:
//
//     .NAME.relief-tmp-HOST-PIDNS-PID-RANDOM
//
// (NAME: the target's file name, cut to 80 bytes; HOST: this host's name;
// PIDNS: the inode of the process's PID namespace, so that two containers
// whose processes are both PID 1 never share a name; RANDOM: 64 random
// bits.)
#include <string>

#include "relief/export.h"

namespace relief {

// Writes `text` to `path` through a temporary file as above. Returns false
// and sets geterror() (naming the system's reason) when it cannot.
RELIEF_API bool write_text_file(const std::string& path, const std::string& text);

// Removes the temporary files this process is writing now. Safe to call
// from a signal handler (it only unlinks): a program's SIGTERM and SIGINT
// handlers call it before they exit, so a killed run leaves no litter.
RELIEF_API void remove_temporary_files() noexcept;

// Removes from `folder` the temporary files left by killed processes of
// this host and PID namespace (a SIGKILL cannot be handled). A file is
// left alone unless its name says it is relief's, of this host and PID
// namespace, and its process is gone: on a farm's shared file system other
// hosts' writers are alive. Returns how many were removed. write_image()
// and the other writers do this once per folder and process.
RELIEF_API int remove_stale_temporary_files(const std::string& folder);

// Why `path` cannot be an output name, checked before any work: "" when it
// can. A file name longer than the folder's file system allows, or a path
// with a byte no file system takes (NUL), is refused here rather than
// after minutes of work; so is an existing file that is not a regular file
// or a folder (a device node, FIFO or socket, or a link to one), which the
// output would replace or block on.
RELIEF_API std::string output_name_problem(const std::string& path);

}  // namespace relief
