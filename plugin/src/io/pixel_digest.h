// SPDX-License-Identifier: Apache-2.0
#pragma once
// What --update checks an output by besides its job digest: a digest of
// its pixels as the file stores them, written beside the job digest
// ("JOB.PIXELS") and read back by recorded_digest() (recorded_digest.cpp).
#include <string>

#include <OpenImageIO/imagebuf.h>

namespace relief::detail {

// The pixels' digest (XXH3-64, 16 hex digits) as `format` holds them; ""
// where the file's values may change on the way (an alpha channel may be
// associated or not: PNG), whose digest would never match.
std::string pixel_digest(const OIIO::ImageBuf& image, OIIO::TypeDesc format);

}  // namespace relief::detail
