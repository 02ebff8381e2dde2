// SPDX-License-Identifier: Apache-2.0
// Reading raw image data and writing outputs atomically.
#include "relief/imageio.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <memory>
#include <system_error>
#include <sys/stat.h>
#include <vector>

#include "callbacks.h"
#include "error_state.h"
#include "library_output.h"
#include "device/memory_budget.h"  // host/: no OpenCL types
#include "relief/output_files.h"
#include "relief/version.h"
#include "pixel_digest.h"
#include "temporary_file.h"

namespace relief {

namespace fs = std::filesystem;
using OIIO::ImageBuf;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

std::string input_file_problem(const std::string& path)
{
    if (path.find('\0') != std::string::npos)
        return "the name holds a NUL byte";
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0)
        return errno == ENOENT ? "no such file" : std::strerror(errno);
    // A FIFO or a device never ends (/dev/zero): hashing or probing it
    // would hang.
    if (S_ISDIR(st.st_mode))
        return "it is a folder";
    if (!S_ISREG(st.st_mode))
        return std::string("not a regular file (") +
               (S_ISCHR(st.st_mode)    ? "a character device"
                : S_ISBLK(st.st_mode)  ? "a block device"
                : S_ISFIFO(st.st_mode) ? "a FIFO"
                : S_ISSOCK(st.st_mode) ? "a socket"
                                       : "not a file") +
               ")";
    if (st.st_size == 0)
        return "the file is empty";
    return "";
}

bool read_image(ImageBuf& dst, const std::string& path)
{
    const detail::LibraryOutput quiet;  // the image libraries print nothing
    if (const std::string why = input_file_problem(path); !why.empty()) {
        detail::set_error("cannot read '" + path + "': " + why);
        return false;
    }
    ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    dst.reset(path, 0, 0, nullptr, &config);
    // The pixels stay in the file's own type where the operations read that
    // type as it is (8 and 16 bit, half, float): a 16384^2 RGB map is then
    // 0.8 GB in memory, not 3.2 GB of floats. Other types become float.
    TypeDesc keep = TypeDesc::FLOAT;
    if (dst.init_spec(path, 0, 0)) {
        const ImageSpec& file = dst.nativespec();
        const TypeDesc t = file.format;
        if (file.channelformats.empty() &&
            (t == TypeDesc::UINT8 || t == TypeDesc::UINT16 || t == TypeDesc::HALF))
            keep = t;
        // A header may claim any size: refuse before allocating what the
        // machine does not have, rather than be killed part way through.
        // (Saturating: a hostile header's product must not wrap to little.)
        host::Bytes bytes = keep.size();
        for (int factor : {file.width, file.height, file.depth, file.nchannels})
            if (__builtin_mul_overflow(bytes, host::Bytes(std::max(factor, 1)), &bytes))
                bytes = ~host::Bytes(0);
        std::string why;
        try {
            why = host::refuse_host(bytes);
        } catch (const std::exception& e) {
            why = e.what();
        }
        if (!why.empty()) {
            detail::set_error("cannot read '" + path + "': " + why);
            dst.clear();
            return false;
        }
    }
    if (!dst.read(0, 0, /*force=*/true, keep) || dst.has_error()) {
        std::string why = dst.geterror();
        if (why.empty())
            why = OIIO::geterror();
        // OIIO's PNM reader, for one, fails a truncated file without a word.
        if (why.empty())
            why = "the file is damaged or truncated (the image library gave no reason)";
        while (!why.empty() && why.back() == '\n')
            why.pop_back();
        for (std::size_t at; (at = why.find('\n')) != std::string::npos;)
            why.replace(at, 1, "; ");  // one message, one line
        detail::set_error("cannot read '" + path + "': " + why);
        dst.clear();
        return false;
    }
    if (dst.spec().width <= 0 || dst.spec().height <= 0) {
        detail::set_error("cannot read '" + path + "': the image has no pixels");
        dst.clear();
        return false;
    }
    // A digest describes the file it is in: it must not travel with the
    // pixels into another file (a stale one would make --update skip).
    ImageSpec& spec = dst.specmod();
    spec.erase_attribute("relief:digest");
    std::string description = spec.get_string_attribute("ImageDescription");
    const std::size_t at = description.find("relief:digest=");
    if (at != std::string::npos) {
        const std::size_t end = description.find('\n', at);
        // the line and the line break before (or after) it
        const std::size_t from = at > 0 && description[at - 1] == '\n' ? at - 1 : at;
        description.erase(from, (end == std::string::npos ? description.size() : end + (from == at)) - from);
        if (description.empty())
            spec.erase_attribute("ImageDescription");
        else
            spec.attribute("ImageDescription", description);
    }
    // An integer file of normals or levels holds them encoded ((v + 1)/2,
    // the level as the code): read back, they are plain data, and writing
    // them again must not encode them twice.
    const std::string method = spec.get_string_attribute("relief:method");
    const TypeDesc stored = dst.nativespec().format;
    if ((method == "normals" || method == "tessellation") &&
        (stored.basetype == TypeDesc::UINT8 || stored.basetype == TypeDesc::UINT16))
        spec.erase_attribute("relief:method");
    return true;
}

namespace {

// Extensions whose writers have no float pixels.
bool integer_only_format(const std::string& ext)
{
    static const char* exts[] = {".png", ".jpg", ".jpeg", ".tga",  ".bmp", ".ppm",
                                 ".pgm", ".pnm", ".gif",  ".webp", ".jp2"};
    for (const char* e : exts)
        if (ext == e)
            return true;
    return false;
}

std::string lowercase(std::string s)
{
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
    return s;
}

void say(const WriteOptions& o, Severity s, const std::string& msg)
{
    if (o.on_message) {
        const detail::InCallback in;
        o.on_message(s, msg);
    }
}

// The file under an image writer: remembers the first write that did not
// go through (a full disk, a file size limit) and why.
class CheckedFile final : public OIIO::Filesystem::IOFile {
public:
    explicit CheckedFile(std::FILE* f) : IOFile(f, Write) {}
    size_t write(const void* buf, size_t size) override { return note(IOFile::write(buf, size), size); }
    size_t pwrite(const void* buf, size_t size, int64_t offset) override
    {
        return note(IOFile::pwrite(buf, size, offset), size);
    }
    int error_number() const { return errno_; }

private:
    size_t note(size_t done, size_t wanted)
    {
        if (done != wanted && errno_ == 0)
            errno_ = errno ? errno : EIO;
        return done;
    }
    int errno_ = 0;
};

// Writes `image` into the temporary file `tmp` for `target` as `format`
// with `compression` (empty: the format's default); returns "" or why not.
// Not through ImageBuf::write: it ignores the writer's close(), where PNG
// and TIFF finish their files, and OIIO 2.4's PNG writer reports success
// for a file the disk could not hold. So the bytes go through CheckedFile
// (which keeps the first failed write's errno for the message), and the
// stream's error, flush, fsync and close are checked by tmp.close().
std::string write_file(const ImageBuf& image, const fs::path& target, detail::TemporaryFile& tmp,
                       TypeDesc format, const std::string& compression)
{
    // The writer is chosen by the target's extension: the temporary name
    // ends otherwise, so that no glob of the extension picks it up.
    const std::string ext = lowercase(target.extension().string());
    auto out = OIIO::ImageOutput::create(ext.empty() ? target.string() : ext.substr(1));
    if (!out)
        return OIIO::geterror();
    ImageSpec spec = image.spec();
    spec.tile_width = spec.tile_height = spec.tile_depth = 0;  // scanlines
    spec.set_format(format);
    spec.channelformats.clear();
    if (!compression.empty())
        spec.attribute("compression", compression);
    spec.attribute("Software", std::string("relief ") + version());  // what made the file
    std::string digest = spec.get_string_attribute("relief:digest");
    if (!digest.empty()) {
        // "JOB.PIXELS": the job's digest and the pixels' (see recorded_digest),
        // in the type the file stores (OpenEXR holds 8- and 16-bit integers
        // as half, OpenImageIO's TIFF half as float), for the lossless
        // formats relief writes.
        TypeDesc stored = format;
        if (ext == ".exr" && (format.basetype == TypeDesc::UINT8 || format.basetype == TypeDesc::INT8 ||
                              format.basetype == TypeDesc::UINT16 || format.basetype == TypeDesc::INT16))
            stored = TypeDesc::HALF;
        if ((ext == ".tif" || ext == ".tiff") && format.basetype == TypeDesc::HALF)
            stored = TypeDesc::FLOAT;
        const bool lossless = ext == ".exr" || ext == ".png" || ext == ".tif" || ext == ".tiff";
        if (const std::string pixels = lossless ? detail::pixel_digest(image, stored) : ""; !pixels.empty()) {
            digest += "." + pixels;
            spec.attribute("relief:digest", digest);
        }
    }
    if (!digest.empty() && ext != ".exr" && ext != ".png") {
        // These formats drop custom attributes but keep the description
        // (after relief's own first line, which says how to read the data).
        const std::string d = spec.get_string_attribute("ImageDescription");
        spec.attribute("ImageDescription", (d.empty() ? "" : d + "\n") + "relief:digest=" + digest);
    }
    std::unique_ptr<CheckedFile> file;
    if (out->supports("ioproxy")) {
        file = std::make_unique<CheckedFile>(tmp.stream());
        out->set_ioproxy(file.get());
    }
    bool ok = out->open(tmp.path().string(), spec) && image.write(out.get());
    ok = out->close() && ok;
    std::string why = ok ? "" : out->geterror();
    const int err = file ? file->error_number() : 0;
    file.reset();  // IOFile does not close a FILE* it was given
    if (err)
        why = std::strerror(err);
    try {
        tmp.close();  // flush and fsync: the data is on disk before the rename
    } catch (const std::exception& e) {
        if (why.empty())
            why = e.what();
    }
    if (ok && why.empty())
        return "";
    return why.empty() ? "unknown error" : why;
}

}  // namespace

bool image_size(const std::string& path, int& width, int& height)
{
    const detail::LibraryOutput quiet;  // the image libraries print nothing
    if (!input_file_problem(path).empty())
        return false;  // missing, or a FIFO whose probe would hang
    auto in = OIIO::ImageInput::open(path);
    if (!in) {
        OIIO::geterror();  // (read, so that it does not linger for the next caller)
        return false;
    }
    width = in->spec().width;
    height = in->spec().height;
    return true;
}

bool check_output_path(const std::string& path)
{
    if (const std::string why = output_name_problem(path); !why.empty()) {
        detail::set_error("cannot write " + why);
        return false;
    }
    const fs::path target(path);
    fs::path folder = target.parent_path();
    if (folder.empty())
        folder = ".";
    std::error_code ec;
    if (!fs::is_directory(folder, ec)) {
        detail::set_error("cannot write '" + path + "': the folder '" + folder.string() + "' does not exist");
        return false;
    }
    if (fs::is_directory(target, ec)) {
        detail::set_error("cannot write '" + path + "': it is a folder");
        return false;
    }
    if (!OIIO::ImageOutput::create(path)) {
        OIIO::geterror();  // consume OIIO's pending message; ours is clearer
        detail::set_error("cannot write '" + path + "': unknown image format '" +
                          target.extension().string() + "' (use .exr, .tif, .png, ...)");
        return false;
    }
    return true;
}

bool write_image(const ImageBuf& image, const std::string& path, const WriteOptions& options)
{
    const detail::LibraryOutput quiet;  // the image libraries print nothing
    if (!check_output_path(path))
        return false;
    if (!image.initialized() || image.has_error()) {
        detail::set_error("cannot write '" + path + "': no valid image to write");
        return false;
    }
    const fs::path target(path);
    const std::string ext = lowercase(target.extension().string());

    TypeDesc format = options.format;
    if ((format == TypeDesc::FLOAT || format == TypeDesc::HALF) && integer_only_format(ext)) {
        format = ext == ".png" ? TypeDesc::UINT16 : TypeDesc::UINT8;
        say(options, Severity::Info,
            "'" + path + "': " + ext + " has no float pixels; writing " + format.c_str());
    }

    // relief's results in an integer file: signed data maps [-m, m] to
    // [0, 1] around 0.5; unit normals are (v + 1)/2, the usual encoding;
    // tessellation levels are the code itself.
    ImageBuf mapped;
    const ImageBuf* out = &image;
    const bool integer = format.basetype == TypeDesc::UINT8 || format.basetype == TypeDesc::UINT16;
    const std::string method = image.spec().get_string_attribute("relief:method");
    if (integer && !method.empty()) {
        const ImageSpec& spec = image.spec();
        std::vector<float> px(spec.image_pixels() * spec.nchannels);
        if (!image.get_pixels(image.roi(), TypeDesc::FLOAT, px.data())) {
            detail::set_error("cannot write '" + path + "': its pixels cannot be read: " + image.geterror());
            return false;
        }
        ImageSpec s = spec;
        if (method == "normals" || method == "tessellation") {
            const double top = format.basetype == TypeDesc::UINT8 ? 255.0 : 65535.0;
            for (float& v : px)
                v = method == "normals" ? 0.5f * (v + 1.0f) : float(double(v) / top);
        } else {
            double m = 0.0;
            for (float v : px)
                m = std::max(m, double(std::abs(v)));
            const double scale = m > 0.0 ? 2.0 * m : 1.0;
            const double mid = 0.5;
            for (float& v : px)
                v = float(mid + v / scale);
            // As text: PNG and TIFF keep only string metadata.
            char text[32];
            std::snprintf(text, sizeof text, "%.9g", scale);
            s.attribute("relief:height_scale", text);
            std::snprintf(text, sizeof text, "%.9g", mid);
            s.attribute("relief:height_midlevel", text);
            // TIFF drops custom attributes but keeps the standard description.
            std::snprintf(text, sizeof text, "%.9g", scale);
            s.attribute("ImageDescription",
                        std::string("relief: data = (value - 0.5) * ") + text + " " +
                            std::string(spec.get_string_attribute("relief:height_unit", "units")));
            char msg[256];
            std::snprintf(msg, sizeof msg,
                          "'%s': %s values v hold data = (v - %.1f) * %.9g (scale %.9g %s, mid-level %.1f)",
                          path.c_str(), format.c_str(), mid, scale, scale,
                          spec.get_string_attribute("relief:height_unit", "units").c_str(), mid);
            say(options, Severity::Info, msg);
        }
        mapped.reset(s);
        mapped.set_pixels(mapped.roi(), TypeDesc::FLOAT, px.data());
        out = &mapped;
    }

    std::string compression = options.compression;
    if (compression.empty() && ext == ".exr" && format == TypeDesc::FLOAT)
        compression = "none";

    try {
        // In the target's folder, so the final rename is atomic and never
        // crosses file systems.
        detail::TemporaryFile tmp(target);
        const std::string why = write_file(*out, target, tmp, format, compression);
        if (!why.empty())
            throw std::runtime_error(why);
        tmp.commit();
    } catch (const std::exception& e) {
        detail::set_error("cannot write '" + path + "': " + e.what());
        return false;
    }
    return true;
}

}  // namespace relief
