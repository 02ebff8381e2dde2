// Runs a fuzz target over files instead of under libFuzzer: every file of
// the folders given (the seed corpus, and the inputs that once crashed it),
// so that the ordinary build's ctest (and the sanitizer build's) replays
// them. A folder that does not exist is skipped (no crash kept yet); no
// input at all is an error.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

int main(int argc, char** argv)
{
    namespace fs = std::filesystem;
    int files = 0;
    for (int i = 1; i < argc; ++i) {
        std::error_code ec;
        std::vector<fs::path> entries;
        for (const auto& e : fs::directory_iterator(argv[i], ec))
            if (e.is_regular_file())
                entries.push_back(e.path());
        if (ec && fs::exists(argv[i])) {
            std::fprintf(stderr, "replay: cannot list %s: %s\n", argv[i], ec.message().c_str());
            return 1;
        }
        std::sort(entries.begin(), entries.end());
        for (const fs::path& p : entries) {
            std::ifstream in(p, std::ios::binary);
            const std::vector<char> bytes((std::istreambuf_iterator<char>(in)),
                                          std::istreambuf_iterator<char>());
            std::printf("%s\n", p.c_str());
            std::fflush(stdout);
            LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
            ++files;
        }
    }
    std::printf("replayed %d input(s)\n", files);
    return files > 0 ? 0 : 1;
}
