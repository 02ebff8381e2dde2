// SPDX-License-Identifier: Apache-2.0
// The digests an output records for --update, and the check that its
// pixels still are what was written.
#include "pixel_digest.h"

#include <OpenImageIO/imageio.h>
#include <xxhash.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <vector>

#include "library_output.h"
#include "relief/imageio.h"

namespace relief {

using OIIO::ImageBuf;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

namespace {

// XXH3-64 of an image's rows of `row` bytes, as hex, read in bands of 64
// rows by read(y, end, bytes) (false: no digest, "").
template <class ReadBand>
std::string band_digest(const ImageSpec& spec, std::size_t row, ReadBand read)
{
    std::unique_ptr<XXH3_state_t, XXH_errorcode (*)(XXH3_state_t*)> state(XXH3_createState(), XXH3_freeState);
    if (!state || XXH3_64bits_reset(state.get()) != XXH_OK)
        return "";
    const int band = 64;
    std::vector<unsigned char> bytes(row * std::size_t(band));
    for (int y = spec.y; y < spec.y + spec.height; y += band) {
        const int end = std::min(y + band, spec.y + spec.height);
        if (!read(y, end, bytes.data()))
            return "";
        XXH3_64bits_update(state.get(), bytes.data(), row * std::size_t(end - y));
    }
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016llx", (unsigned long long)XXH3_64bits_digest(state.get()));
    return hex;
}

}  // namespace

namespace detail {

std::string pixel_digest(const ImageBuf& image, TypeDesc format)
{
    const ImageSpec& spec = image.spec();
    if (spec.alpha_channel >= 0 || spec.nchannels == 2 || spec.nchannels == 4)
        return "";
    const std::size_t row = std::size_t(spec.width) * std::size_t(spec.nchannels) * format.size();
    return band_digest(spec, row, [&](int y, int end, unsigned char* bytes) {
        const OIIO::ROI roi(spec.x, spec.x + spec.width, y, end, spec.z, spec.z + 1, 0, spec.nchannels);
        return image.get_pixels(roi, format, bytes);
    });
}

}  // namespace detail

namespace {

// The same digest of a file's pixels as stored (native), read back.
std::string stored_pixel_digest(OIIO::ImageInput& in)
{
    const ImageSpec& spec = in.spec();
    if (spec.tile_width > 0 || spec.width <= 0 || spec.height <= 0 || spec.depth > 1)
        return "";
    return band_digest(spec, spec.scanline_bytes(true), [&](int y, int end, unsigned char* bytes) {
        return in.read_scanlines(0, 0, y, end, spec.z, 0, spec.nchannels, TypeDesc::UNKNOWN, bytes) &&
               in.geterror().empty();
    });
}

// Whether every pixel decodes: for the outputs without a pixel digest.
bool pixels_decode(OIIO::ImageInput& in)
{
    const ImageSpec& spec = in.spec();
    if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0)
        return false;
    // Bands of rows (whole tiles or strips), read in order: a file cut short
    // or damaged inside (a checksum, a compressed stream that does not
    // inflate) fails where its pixels are, whatever keeps its header and
    // size. Uncompressed pixels carry no check: those outputs are trusted
    // as any file is.
    const int rows =
        spec.tile_height > 0 ? spec.tile_height : std::max(1, spec.get_int_attribute("tiff:RowsPerStrip", 1));
    const int band = std::max(rows, (64 + rows - 1) / rows * rows);
    const int depth = std::max(1, spec.depth);
    std::vector<float> pixels(std::size_t(spec.width) * std::size_t(spec.nchannels) * std::size_t(band) *
                              std::size_t(depth));
    for (int y = spec.y; y < spec.y + spec.height; y += band) {
        const int end = std::min(y + band, spec.y + spec.height);
        // OIIO 2.4 returns true for a strip libtiff could not read, with the
        // error set: both count.
        const bool read =
            spec.tile_width > 0
                ? in.read_tiles(0, 0, spec.x, spec.x + spec.width, y, end, spec.z, spec.z + depth, 0,
                                spec.nchannels, TypeDesc::FLOAT, pixels.data())
                : in.read_scanlines(0, 0, y, end, spec.z, 0, spec.nchannels, TypeDesc::FLOAT, pixels.data());
        if (!read || !in.geterror().empty())
            return false;
    }
    return true;
}

}  // namespace

std::string recorded_digest(const std::string& path)
{
    const detail::LibraryOutput quiet;  // the image libraries print nothing
    // Meshes (--mesh) record it near their start: an OBJ or PLY comment
    // "relief:digest=HEX", glTF's asset.extras "relief:digest":"HEX".
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (ext == ".obj" || ext == ".ply" || ext == ".gltf" || ext == ".glb") {
        std::ifstream f(path, std::ios::binary);
        std::string head(1 << 16, '\0');
        f.read(&head[0], std::streamsize(head.size()));
        head.resize(std::size_t(f.gcount()));
        std::size_t at = head.find("relief:digest");
        if (at == std::string::npos)
            return "";
        at += 13;
        while (at < head.size() && (head[at] == '=' || head[at] == '"' || head[at] == ':' || head[at] == ' '))
            ++at;
        std::size_t end = at;
        while (end < head.size() && std::isxdigit(static_cast<unsigned char>(head[end])))
            ++end;
        return head.substr(at, end - at);
    }
    if (!input_file_problem(path).empty())
        return "";  // missing, or a FIFO whose probe would hang
    auto in = OIIO::ImageInput::open(path);
    if (!in) {
        OIIO::geterror();  // consume it: a missing output just means "recompute"
        return "";
    }
    const ImageSpec& spec = in->spec();
    std::string digest = spec.get_string_attribute("relief:digest");
    if (digest.empty()) {
        const std::string d = spec.get_string_attribute("ImageDescription");
        const std::string key = "relief:digest=";
        const std::size_t at = d.find(key);
        if (at != std::string::npos)
            digest = d.substr(at + key.size(), d.find('\n', at) - at - key.size());
    }
    // "JOB.PIXELS": the pixels as stored must hash to PIXELS; a digest
    // without it (a file whose values may change on the way, or an older
    // relief's) must at least decode. A damaged file keeps its header and
    // size: recompute it.
    const std::size_t dot = digest.find('.');
    if (dot != std::string::npos) {
        if (stored_pixel_digest(*in) != digest.substr(dot + 1))
            digest.clear();
        else
            digest.resize(dot);
    } else if (!digest.empty() && !pixels_decode(*in)) {
        digest.clear();
    }
    in->close();
    OIIO::geterror();
    return digest;
}

}  // namespace relief
