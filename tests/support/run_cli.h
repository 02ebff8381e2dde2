// SPDX-License-Identifier: Apache-2.0
#pragma once
// Runs the relief executable and captures its exit code and stderr.
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace relief::test {

struct CliResult {
    int rc;
    std::string err;
    std::string out;
};

inline std::string slurp(const std::filesystem::path& p)
{
    std::ifstream in(p, std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

// The number after "key": in a JSON text, searched from `from` (the first
// occurrence); NaN when the key is not there.
inline double json_number(const std::string& json, const std::string& key, std::size_t from = 0)
{
    const std::size_t at = json.find("\"" + key + "\": ", from);
    return at == std::string::npos ? NAN : std::strtod(json.c_str() + at + key.size() + 4, nullptr);
}

// `env` is prepended to the command ("VAR=value ..."); `args` is shell text.
inline CliResult run_cli(const std::string& args, const std::string& env = "")
{
    namespace fs = std::filesystem;
    fs::path dir = fs::path(RELIEF_TEST_TMP);
    fs::create_directories(dir);
    // Per process: ctest runs test cases in parallel processes.
    const std::string tag = std::to_string(::getpid());
    fs::path out = dir / ("cli." + tag + ".stdout"), err = dir / ("cli." + tag + ".stderr");
    std::string cmd = env + " '" + std::string(RELIEF_CLI) + "' " + args + " >'" + out.string() + "' 2>'" +
                      err.string() + "' </dev/null";
    int status = std::system(cmd.c_str());
    int rc = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    CliResult r{rc, slurp(err), slurp(out)};
    fs::remove(out);
    fs::remove(err);
    return r;
}

}  // namespace relief::test
