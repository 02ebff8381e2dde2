// SPDX-License-Identifier: Apache-2.0
// The operation table's entries for --normals, --tessellation, --mesh and --preview (checking a result): each operation's slots,
// modifiers (what users see, how they set the option structs) and run.
#include "schema.h"

#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "relief/check.h"
#include "relief/mesh.h"
#include "relief/preview.h"
#include "relief/validate.h"

namespace relief::table {

Operation normals_operation()
{
    Operation op;
    op.info = {"normals",
               "height map -> its normal map (3 channels, unit vectors; float files hold [-1, 1], "
               "integer files (v + 1)/2): the inverse of the slopes, by central differences",
               {kHeight},
               {{"normals", 3, 3, "tangent-space normal map in the chosen green convention"}},
               {},
               ""};
    auto n = [](auto& c) -> auto&
    {
        return c.normals;
    };
    op.modifiers = {
        choice(
            "normal", [n](auto& c) -> auto& { return n(c).convention; },
            std::vector<std::pair<std::string, NormalConvention>>{{"opengl", NormalConvention::OpenGL},
                                                                  {"directx", NormalConvention::DirectX}},
            "", "green convention to store: opengl (Y+, G = -n_y) or directx (Y-, G = +n_y)"),
        number(
            detail::limits::surface_scale, [n](auto& c) -> auto& { return n(c).scale; }, "S", "",
            "the height (texels) is multiplied by S first"),
        choice(
            "boundary", [n](auto& c) -> auto& { return n(c).boundary; }, kBoundaryWords, "",
            "periodic: differences wrap; free: one-sided at the edges; X,Y: x's and y's "
            "(periodic,free); auto: the height's own (relief:parameters), else each axis periodic "
            "when the height is continuous across its wrap seam"),
    };
    op.validate = [](const OperationCall& c) { return relief::validate(c.normals); };
    op.run = [](ImageBuf& dst, const OperationCall& c, const std::vector<const ImageBuf*>& in) {
        return relief::normals(dst, *in[0], c.normals);
    };
    return op;
}

// patch, error, scale: shared by --tessellation and --mesh.
template <class F>
std::vector<Modifier> tessellation_modifiers(F t)
{
    return {
        number(
            detail::limits::patch, [t](auto& c) -> auto& { return t(c).patch; }, "P", "",
            "patch size: one level per P x P texels"),
        number(
            detail::limits::error, [t](auto& c) -> auto& { return t(c).error; }, "E", "",
            "the largest deviation of the tessellated surface from S x height at a texel centre"),
        number(
            detail::limits::surface_scale, [t](auto& c) -> auto& { return t(c).scale; }, "S", "",
            "the surface is S x height (texels)"),
    };
}

Operation tessellation_operation()
{
    Operation op;
    op.info = {"tessellation",
               "height map -> tessellation levels (1 channel, ceil(W/P) x ceil(H/P)): per patch the "
               "lowest level 1..64 whose L x L quads stay within E of the surface; flat patches 1",
               {kHeight},
               {{"levels", 1, 1, "level per patch, 1..64"}},
               {},
               ""};
    op.modifiers = tessellation_modifiers([](auto& c) -> auto& { return c.tessellation; });
    op.validate = [](const OperationCall& c) { return relief::validate(c.tessellation); };
    op.run = [](ImageBuf& dst, const OperationCall& c, const std::vector<const ImageBuf*>& in) {
        return relief::tessellation(dst, *in[0], c.tessellation);
    };
    return op;
}

Operation mesh_operation()
{
    Operation op;
    op.info = {"mesh",
               "height map -> a file holding the displaced surface, tessellated per patch at its "
               "level and stitched without cracks (OBJ, PLY, glTF .gltf/.glb by extension; x, y in "
               "texels, z = S x height); the height stays on the stack",
               {kHeight},
               {{"height", 1, 4096, "the input, unchanged"}},
               {},
               ""};
    auto k = [](auto& c) -> auto&
    {
        return c.mesh;
    };
    op.modifiers = tessellation_modifiers([k](auto& c) -> auto& { return k(c).tessellation; });
    Modifier out;
    out.info.name = "out";
    out.info.type = ModifierType::Output;
    out.info.placeholder = "FILE";
    out.info.meaning = "the mesh file: .obj, .ply, .gltf or .glb (required)";
    out.set = [k](OperationCall& c, const std::string& text, double) {
        const std::string problem = mesh_path_problem(text);
        if (!problem.empty())
            throw std::invalid_argument(problem);
        k(c).out = text;
    };
    out.get = [k](const OperationCall& c) { return k(c).out.empty() ? std::string("none") : k(c).out; };
    out.path = [k](const OperationCall& c) { return k(c).out; };
    op.modifiers.push_back(out);
    op.validate = [k](const OperationCall& c) { return relief::validate(k(c)); };
    op.run = [k](ImageBuf& dst, const OperationCall& c, const std::vector<const ImageBuf*>& in) {
        MeshOptions o = k(c);
        if (!c.file_digest.empty())
            o.digest = c.file_digest;
        return relief::mesh(dst, *in[0], o);
    };
    return op;
}

Operation preview_operation()
{
    Operation op;
    op.info = {"preview",
               "normal map and height -> one labelled 8-bit RGB sheet: both lit under the same light, "
               "an emboss view, the angular error (heat map, degrees) and the height (texels)",
               {kNormals, kHeight},
               {{"sheet", 3, 3, "sRGB preview sheet"}},
               {},
               ""};
    auto k = [](auto& c) -> auto&
    {
        return c.preview;
    };
    op.modifiers = decoding_modifiers([k](auto& c) -> auto& { return k(c).normals; });
    Modifier light;
    light.info.name = "light";
    light.info.type = ModifierType::Text;
    light.info.placeholder = "AZ,EL";
    light.info.unit = "degrees";
    light.info.meaning =
        "key light: azimuth counter-clockwise from the image's right (90 = from the top), in " +
        detail::range_text(detail::limits::light_azimuth) + "; elevation above the surface, in " +
        detail::range_text(detail::limits::light_elevation);
    light.set = [k](OperationCall& c, const std::string& text, double) {
        // The written form; the angles' ranges are validate()'s.
        const std::size_t comma = text.find(',');
        double az = 0.0, el = 0.0;
        if (comma == std::string::npos || !read_number(text.substr(0, comma), az) ||
            !read_number(text.substr(comma + 1), el))
            throw std::invalid_argument("light=" + text + ": write light=AZ,EL (degrees, e.g. 135,45)");
        k(c).azimuth = float(az);
        k(c).elevation = float(el);
    };
    light.get = [k](const OperationCall& c) {
        return number_text(k(c).azimuth) + "," + number_text(k(c).elevation);
    };
    Modifier env;
    env.info.name = "env";
    env.info.type = ModifierType::File;
    env.info.choices = {"sky"};
    env.info.placeholder = "FILE";
    env.info.meaning = "lat-long environment image for the diffuse light (its 9 spherical-harmonic "
                       "irradiance coefficients; 8/16-bit files are sRGB); sky: a procedural sky";
    env.set = [k](OperationCall& c, const std::string& text, double) {
        k(c).env = text == "sky" ? "" : text;
    };
    env.get = [k](const OperationCall& c) { return k(c).env.empty() ? std::string("sky") : k(c).env; };
    env.path = [k](const OperationCall& c) { return k(c).env; };
    op.modifiers.push_back(light);
    op.modifiers.push_back(env);
    op.modifiers.push_back(choice(
        "boundary", [k](auto& c) -> auto& { return k(c).boundary; }, kBoundaryWords, "",
        "of the height's differences, as --normals"));
    op.validate = [k](const OperationCall& c) { return relief::validate(k(c)); };
    op.run = [k](ImageBuf& dst, const OperationCall& c, const std::vector<const ImageBuf*>& in) {
        return relief::preview(dst, *in[0], *in[1], k(c));
    };
    return op;
}

}  // namespace relief::table
