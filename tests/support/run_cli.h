#pragma once
// Runs the relief executable and captures its exit code and stderr.
#include <sys/wait.h>

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

// `env` is prepended to the command ("VAR=value ..."); `args` is shell text.
inline CliResult run_cli(const std::string& args, const std::string& env = "")
{
    namespace fs = std::filesystem;
    fs::path dir = fs::path(RELIEF_TEST_TMP);
    fs::create_directories(dir);
    fs::path out = dir / "cli.stdout", err = dir / "cli.stderr";
    std::string cmd = env + " '" + std::string(RELIEF_CLI) + "' " + args + " >'" + out.string() +
                      "' 2>'" + err.string() + "' </dev/null";
    int status = std::system(cmd.c_str());
    int rc = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    return {rc, slurp(err), slurp(out)};
}

} // namespace relief::test
