// SPDX-License-Identifier: Apache-2.0
#include "colour.h"

#include <OpenColorIO/OpenColorIO.h>

#include <algorithm>
#include <cstdlib>
#include <stdexcept>

#include "device/cancel.h"

namespace OCIO = OCIO_NAMESPACE;

namespace relief::detail {

namespace {

bool has_env_config()
{
    const char* env = std::getenv("OCIO");
    return env && *env;
}

// Names under which configs commonly carry sRGB-encoded textures.
const char* kSrgbNames[] = {"sRGB",
                            "sRGB - Texture",
                            "srgb_tx",
                            "Utility - sRGB - Texture",
                            "Input - Generic - sRGB - Texture",
                            "srgb_texture",
                            "sRGB Encoded Rec.709 (sRGB)"};

OCIO::ConstProcessorRcPtr processor(const std::string& space, bool decode)
{
    if (!has_env_config()) {
        if (space != "sRGB")
            throw std::runtime_error("colour space '" + space +
                                     "' needs an OCIO config: set $OCIO (without one relief "
                                     "knows sRGB and linear)");
        auto t = OCIO::ExponentWithLinearTransform::Create();
        const double gamma[4] = {2.4, 2.4, 2.4, 1.0}, offset[4] = {0.055, 0.055, 0.055, 0.0};
        t->setGamma(gamma);
        t->setOffset(offset);
        // Forward: pow((x + offset)/(1 + offset), gamma), i.e. decoding.
        t->setDirection(decode ? OCIO::TRANSFORM_DIR_FORWARD : OCIO::TRANSFORM_DIR_INVERSE);
        return OCIO::Config::CreateRaw()->getProcessor(t);
    }
    OCIO::ConstConfigRcPtr config = OCIO::GetCurrentConfig();
    std::string name;
    if (config->getColorSpace(space.c_str()))
        name = space;
    else if (space == "sRGB")
        for (const char* n : kSrgbNames)
            if (config->getColorSpace(n)) {
                name = n;
                break;
            }
    if (name.empty())
        throw std::runtime_error("the OCIO config ($OCIO) has no colour space '" + space + "'");
    return decode ? config->getProcessor(name.c_str(), OCIO::ROLE_SCENE_LINEAR)
                  : config->getProcessor(OCIO::ROLE_SCENE_LINEAR, name.c_str());
}

void apply(std::vector<float>& px, int nch, const std::string& space, bool decode)
{
    auto cpu = processor(space, decode)->getDefaultCPUProcessor();
    const std::size_t n = px.size() / nch;
    if (nch == 3 || nch == 4) {
        // In bands of 64K pixels, a cancel asked between them (a 1024^2 map
        // took 90 ms at once here).
        const std::size_t band = 65536;
        for (std::size_t first = 0; first < n; first += band) {
            host::stop_if_cancelled();
            OCIO::PackedImageDesc desc(px.data() + first * std::size_t(nch), long(std::min(band, n - first)),
                                       1, nch);
            cpu->apply(desc);
        }
        return;
    }
    // One or two channels: each converted as a grey (or the first two as R, G).
    std::vector<float> rgb(3 * n);
    const int used = std::min(nch, 3);
    for (std::size_t i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c)
            rgb[3 * i + c] = px[i * nch + std::min(c, used - 1)];
    OCIO::PackedImageDesc desc(rgb.data(), long(n), 1, 3);
    cpu->apply(desc);
    for (std::size_t i = 0; i < n; ++i)
        for (int c = 0; c < used; ++c)
            px[i * nch + c] = rgb[3 * i + c];
}

}  // namespace

void to_linear(std::vector<float>& px, int nch, const std::string& space)
{
    apply(px, nch, space, true);
}

void from_linear(std::vector<float>& px, int nch, const std::string& space)
{
    apply(px, nch, space, false);
}

std::string colour_engine()
{
    if (has_env_config())
        return std::string("OCIO config ") + std::getenv("OCIO");
    return "OCIO raw config with the sRGB curve (gamma 2.4, offset 0.055; set $OCIO for a studio config)";
}

std::string ocio_version()
{
    return OCIO::GetVersion();
}

}  // namespace relief::detail
