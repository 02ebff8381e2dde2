// Fuzz target: a damaged or hostile image file, read and decoded into the
// DDM as `relief FILE --slopes` would. The first byte picks the format
// (PNG, EXR, TIFF, TGA: the file's name ends so), the rest is the file.
// Reading may fail (with a message); a read map goes through the DDM on the
// OpenCL device. A crash, a hang, a sanitizer report or a refusal without
// a message is a bug.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <OpenImageIO/imagebuf.h>

#include "relief/errors.h"
#include "relief/imageio.h"
#include "relief/slopes.h"

namespace {

// A new name for each input (removed after it): the image library caches
// what it read by file name.
std::string scratch(int format)
{
    static const char* ext[] = {".png", ".exr", ".tif", ".tga"};
    static unsigned long count = 0;
    const char* dir = std::getenv("TMPDIR");
    return std::string(dir && *dir ? dir : "/tmp") + "/relief-fuzz-decode-" + std::to_string(::getpid()) +
           "-" + std::to_string(count++) + ext[format];
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    if (size == 0)
        return 0;
    const std::string path = scratch(data[0] % 4);
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f)
        return 0;
    std::fwrite(data + 1, 1, size - 1, f);
    std::fclose(f);

    OIIO::ImageBuf map;
    const bool read = relief::read_image(map, path);
    std::remove(path.c_str());
    if (!read) {
        if (relief::geterror().empty())
            __builtin_trap();  // a refusal says why
        return 0;
    }
    // Large maps decode the same way as small ones; they only slow the
    // search down (the read above has already seen the whole file).
    const OIIO::ROI roi = map.roi();
    if (std::size_t(roi.width()) * std::size_t(roi.height()) > (std::size_t(1) << 16))
        return 0;
    OIIO::ImageBuf slopes;
    if (!relief::slopes(slopes, map) && relief::geterror().empty())
        __builtin_trap();
    return 0;
}
