// SPDX-License-Identifier: Apache-2.0
#pragma once
// Reading and writing images the way relief needs them.
#include <OpenImageIO/imagebuf.h>

#include <string>

#include "options.h"

#include "relief/export.h"

namespace relief {

// Reads the first subimage of `path` as raw data: no colour conversion, and
// alpha left unassociated (PNG readers otherwise premultiply RGB by alpha,
// which corrupts normal maps whose alpha holds a height). Pixels are
// converted to float in memory; dst.nativespec().format keeps the file's
// type (UNORM decoding depends on it). Returns false and sets geterror() for
// a missing, empty, truncated or non-image file.
RELIEF_API bool read_image(OIIO::ImageBuf& dst, const std::string& path);

// Why `path` cannot be read as an input file, without opening it: "no such
// file", "it is a folder", "not a regular file (a FIFO)" (devices and FIFOs
// never end: relief reads regular files only), "the file is empty"; "" when
// it can. read_image() checks this first.
RELIEF_API std::string input_file_problem(const std::string& path);

// Whether an image could be written to `path`: its folder exists, it is not
// a folder, and its extension names a format OIIO can write. Returns false
// and sets geterror() otherwise. write_image() checks this first; front ends
// call it early to refuse a bad output before any work.
RELIEF_API bool check_output_path(const std::string& path);

struct WriteOptions {
    // Pixel type of the file: FLOAT (default), HALF, UINT16 or UINT8.
    OIIO::TypeDesc format = OIIO::TypeDesc::FLOAT;
    // The file's compression, by OIIO's names ("zip", "piz", "none", ...).
    // Empty: "none" for float OpenEXR (relief's float results are close to
    // incompressible: zip saves about 4% of a 2048^2 height map and costs
    // 0.3 s, six times the write itself), the format's default otherwise.
    std::string compression;
    // Where to report the integer mapping (scale and mid-level).
    std::function<void(Severity, const std::string&)> on_message;
};

// Writes `image` to `path` atomically: into a temporary file in the same
// folder, renamed over `path` only when complete, so a failure leaves no
// partial file and does not touch an existing one.
//
// Integer formats store relief's signed results (heights, slopes: images
// with a relief:method attribute) as value = midlevel + data / scale, with
// midlevel 0.5 and scale = 2 * max|data| (so the data fits [0, 1]); the file
// records relief:height_scale and relief:height_midlevel (as text, which
// every format keeps), and data =
// (value - midlevel) * scale. Other images are written as they are.
//
// A "relief:digest" attribute of the image (what `relief --update`
// compares) is kept in every format that keeps any metadata: as itself in
// OpenEXR and PNG, as a "relief:digest=HEX" line of ImageDescription in
// TIFF, JPEG and Targa.
RELIEF_API bool write_image(const OIIO::ImageBuf& image, const std::string& path,
                            const WriteOptions& options = {});

// The width and height of the image file at `path`, from its header (its
// first subimage), quietly as every read; false when it cannot be read
// (the error is left for the read to report: geterror() is not set).
RELIEF_API bool image_size(const std::string& path, int& width, int& height);

// The relief:digest that the image file at `path` records, read from its
// header; "" when it records none or cannot be read, or when its pixels
// are cut short (a truncated file keeps its header): the last scanline is
// read (a PNG's closing chunk checked), not the whole image.
RELIEF_API std::string recorded_digest(const std::string& path);

// Where the image libraries' own diagnostics go ("libpng error: ...",
// "OIIO DEBUG: ..."), as Severity::Debug lines, when no operation is
// running on the thread (an operation's go to its Execution::on_message).
// relief captures them from stderr around each call into those libraries
// and never lets them through: without a handler they are dropped.
RELIEF_API void set_library_messages(std::function<void(Severity, const std::string&)> handler);

}  // namespace relief
