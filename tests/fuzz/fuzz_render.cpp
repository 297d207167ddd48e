// Fuzz target: the verification rasterizer (render_scene) on a tiny image of a fuzzed glTF scene — morph
// targets, skins, materials and alpha modes, embedded textures (decoded through stb_image), every render
// mode, the camera (perspective, orthographic, automatic framing, near plane).
//
// Input: a 64-byte header (read_header: format, size at most 32 × 32, mode, ssaa 1..2, camera, light,
// flags), then a .glb or .gltf file. Bit 3 of the flags loads with allow_non_finite, so NaN/Inf positions
// reach the rasterizer (which must skip those triangles).
// Properties: far-out options are refused (never an ok result); an ok render has width × height RGBA colour
// values in [0, 1], the matching 8-bit buffer, depths that are not NaN (>= 0 in perspective), and finite
// attribute ranges.
#include "fuzz_common.h"

#include <furrow/render.h>

#include <cmath>

using namespace furrow;

namespace {

constexpr size_t kHeader = 64;

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size < kHeader || size > 256 * 1024) return 0;
    fuzz::Reader r(data, kHeader);
    const uint8_t flags = r.u8();
    RenderOptions o;
    o.width = 1 + r.u8() % 32;
    o.height = 1 + r.u8() % 32;
    o.mode = RenderMode(r.u8() % 7);
    o.ssaa = 1 + r.u8() % 2;
    RenderCamera& c = o.camera;
    c.orthographic = flags & 0x10;
    if (flags & 0x20) c.eye = std::array<double, 3>{r.f32(), r.f32(), r.f32()};
    if (flags & 0x40) c.target = std::array<double, 3>{r.range(-10, 10), r.range(-10, 10), r.range(-10, 10)};
    c.up = {r.range(-1, 1), r.range(-1, 1), r.range(-1, 1)};
    c.fov_degrees = r.range(0.5, 179.5);
    c.ortho_height = r.flag() ? r.range(0, 100) : 0.0;
    c.near_plane = r.flag() ? std::abs(double(r.f32())) : 0.0;
    if (!std::isfinite(c.near_plane)) c.near_plane = 0;
    if (r.flag()) o.background = std::array<float, 3>{float(r.range(0, 1)), float(r.range(0, 1)), float(r.range(0, 1))};
    o.light_direction = {float(r.range(-1, 1)), float(r.range(-1, 1)), float(r.range(-1, 1))};
    o.ambient = float(r.range(0, 1));
    o.legend = r.flag();
    o.mipmaps = !r.flag();                 // the sampler's mip chain (trilinear, level of detail), or the base level
    o.subpixel_bits = 1 + r.u8() % 8;
    const bool far_out = flags & 0x80;
    if (far_out) {
        switch (r.u8() % 4) {
        case 0: o.width = 0; break;
        case 1: o.height = 16385 + r.u16(); break;
        case 2: o.ssaa = 9 + r.u8(); break;
        default: c.fov_degrees = 180 + r.range(0, 1000); c.orthographic = false; break;
        }
    }

    LoadOptions lo;
    lo.allow_non_finite = flags & 0x08;
    Scene scene;
    if (Status l = load_scene_from_memory(scene, data + kHeader, size - kHeader, flags & 1 ? ".gltf" : ".glb", lo); !l.ok()) {
        fuzz::rejected("load_scene_from_memory", l);
        return 0;
    }
    for (const Image& im : scene.images)
        if (!fuzz::small_image(im.encoded.data(), im.encoded.size())) return 0;
    if (o.mode == RenderMode::attribute) { // the scene's first custom attribute, or one it lacks (an error)
        o.attribute = "_MISSING";
        for (const Mesh& m : scene.meshes)
            for (const Primitive& p : m.primitives)
                if (!p.custom.empty()) o.attribute = p.custom[0].name;
    }

    RenderResult out;
    Status s = render_scene(out, scene, o);
    if (far_out) FUZZ_CHECK(!s.ok(), "far-out options were accepted");
    if (!s.ok()) {
        if (!far_out) fuzz::rejected("render_scene", s);
        return 0;
    }
    const size_t px = size_t(o.width) * size_t(o.height);
    FUZZ_CHECK(out.color.width == o.width && out.color.height == o.height && out.color.channels == 4 &&
                   out.color.pixels.size() == px * 4,
               "colour image %dx%dx%d", out.color.width, out.color.height, out.color.channels);
    for (float v : out.color.pixels) FUZZ_CHECK(v >= 0 && v <= 1, "colour value %g", double(v));
    FUZZ_CHECK(out.rgba8.size() == px * 4, "rgba8 size %zu", out.rgba8.size());
    FUZZ_CHECK(out.depth.pixels.size() == px, "depth size %zu", out.depth.pixels.size());
    // Eye-space distances: an orthographic view may see (and keep) surfaces behind the eye's plane.
    for (float d : out.depth.pixels) FUZZ_CHECK((d >= 0 || c.orthographic) && !std::isnan(d), "depth %g", double(d));
    FUZZ_CHECK(std::isfinite(out.attribute_min) && std::isfinite(out.attribute_max), "attribute range %g..%g",
               double(out.attribute_min), double(out.attribute_max));
    return 0;
}
