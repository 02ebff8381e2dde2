// SPDX-License-Identifier: Apache-2.0
#pragma once
// Compiled OpenCL programs, relief's and VkFFT's (fft_plan.cpp), kept on
// disk between processes, so that a map does not pay for compiling kernels
// that an earlier process compiled (PoCL's own cache still runs Clang's
// preprocessor on every build from source; a program made from a binary
// skips the compiler front end). One file per program, named by a hash of
// everything the binary depends on: the device, its driver, the source and
// the build options. A cache: every failure falls back to building from
// source.
#include <optional>
#include <string>
#include <vector>

namespace relief::host {

class BinaryCache {
public:
    // $RELIEF_CACHE_DIR, else $XDG_CACHE_HOME/relief, else $HOME/.cache/relief;
    // empty (no cache) when RELIEF_CACHE_DIR is "off" or no folder is known.
    static std::string folder();

    // The 32-hex-digit name of an entry: XXH3-128 of `parts`, each preceded
    // by its length (so that no two lists feed the same bytes).
    static std::string key(const std::vector<std::string>& parts);

    // The bytes stored under `key`, when the file exists and is intact (its
    // checksum matches); nothing otherwise.
    static std::optional<std::string> load(const std::string& key);

    // Stores `bytes` under `key` atomically (a temporary file renamed into
    // place, so concurrent processes on a shared folder never see a partial
    // file). Failures (read-only folder, full disk) are ignored.
    static void store(const std::string& key, const std::string& bytes);
};

}  // namespace relief::host
