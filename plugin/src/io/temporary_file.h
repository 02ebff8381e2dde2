// SPDX-License-Identifier: Apache-2.0
#pragma once
// The temporary file behind every output (see relief/output_files.h).
#include <cstdio>
#include <filesystem>

namespace relief::detail {

class TemporaryFile {
public:
    // Creates the exclusive temporary file for `target` in its folder, after
    // removing the folder's stale ones (once per folder and process).
    // Throws std::runtime_error naming the system's reason.
    explicit TemporaryFile(const std::filesystem::path& target);
    // Removes the file unless commit() renamed it.
    ~TemporaryFile();
    TemporaryFile(const TemporaryFile&) = delete;
    TemporaryFile& operator=(const TemporaryFile&) = delete;

    const std::filesystem::path& path() const { return path_; }
    // The open file, for writing; its first call hands the descriptor over
    // to a stdio stream that close() ends.
    std::FILE* stream();
    // Flushes, syncs and closes the stream (when one was taken). Throws
    // std::runtime_error with the system's reason (a full disk).
    void close();
    // Renames the file over the target: the output appears whole or not at
    // all. Throws std::runtime_error with the system's reason.
    void commit();

private:
    std::filesystem::path target_, path_;
    int fd_ = -1;
    std::FILE* stream_ = nullptr;
    int slot_ = -1;
    bool committed_ = false;
};

}  // namespace relief::detail
