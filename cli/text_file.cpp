#include "text_file.h"

#include <cstdio>
#include <stdexcept>

#include <unistd.h>

namespace relief::cli {

void write_text_atomically(const std::string& path, const std::string& text, const std::string& what)
{
    const std::string tmp = path + ".relief-tmp-" + std::to_string(::getpid());
    std::FILE* f = std::fopen(tmp.c_str(), "wb");
    bool ok = f && std::fwrite(text.data(), 1, text.size(), f) == text.size();
    // On disk before the rename, as the images are.
    ok = ok && std::fflush(f) == 0 && ::fsync(::fileno(f)) == 0;
    ok = f && (std::fclose(f) == 0) && ok;
    if (!ok || std::rename(tmp.c_str(), path.c_str()) != 0) {
        std::remove(tmp.c_str());
        throw std::runtime_error("cannot write " + what + " '" + path + "'");
    }
}

} // namespace relief::cli
