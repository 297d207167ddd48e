// Internals of the verification rasterizer (render.h), shared by render.cpp (scene -> draws, camera),
// render_raster.cpp (clip, set up, bin, rasterize, resolve) and render_image.cpp (textures, colours, legend,
// metrics). Nothing here is public.
#pragma once

#include <furrow/render.h>

#include <furrow_kernel/affine.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace furrow::render_detail {

using kernel::Mat4; // column-major, like glTF (furrow_kernel/affine.h)

// A decoded base-colour texture with its sampler (render_texture.cpp): linear RGBA floats (sRGB decoded once,
// so filtering is linear), and the mip chain when the sampler's minFilter asks for one.
struct MipLevel {
    int width = 0, height = 0;
    std::vector<float> rgba;
};
enum class MipMode : uint8_t { none, nearest, linear }; // minFilter NEAREST/LINEAR, *_MIPMAP_NEAREST, *_MIPMAP_LINEAR
struct DecodedTexture {
    std::vector<MipLevel> levels;       // [0] = the image; then glGenerateMipmap's chain down to 1×1
    int wrap_s = 10497, wrap_t = 10497; // glTF REPEAT / CLAMP_TO_EDGE (33071) / MIRRORED_REPEAT (33648)
    bool mag_nearest = false;           // magFilter NEAREST (9728)
    bool min_nearest = false;           // minFilter NEAREST or NEAREST_MIPMAP_*: nearest texel within a level
    MipMode mip = MipMode::linear;
    float mag_threshold = 0;            // λ <= this magnifies (GL's c)
    bool needs_lod() const { return mip != MipMode::none || mag_nearest != min_nearest; }
};
// Applies a glTF sampler (-1 = unset: three.js's defaults) and builds the mip chain when it mip-maps and
// `mipmaps` is true; unknown values get a warning and the default.
void set_sampler(DecodedTexture& t, int mag_filter, int min_filter, int wrap_s, int wrap_t, bool mipmaps,
                 std::vector<std::string>& warnings, const std::string& name);
// The filtered texel at (u, v) for level of detail lod = log2(texels per output pixel) at level 0; NaN = no
// derivative known (magnification).
std::array<float, 4> sample_texture(const DecodedTexture& t, float u, float v, float lod);

inline int64_t fast_floor(double x) { // std::floor is a libm call on baseline x86-64; |x| is bounded by the callers
    int64_t k = int64_t(x);
    return k - (double(k) > x);
}

// One vertex after the vertex stage: clip-space position, then what the pixel stage interpolates.
struct Vert {
    float x, y, z, w; // clip space; z/w is reversed depth: 1 at the near plane, decreasing away from it
    float n[3];       // normal: view space (shaded modes) or world space (normals mode); unnormalized
    float uv[2];      // the texture's set in shaded modes, TEXCOORD_0 in uv mode
    float c[4];       // COLOR_0, linear RGBA (1 when absent)
    float s;          // attribute mode: the scalar mapped to [0,1]; < 0 = this primitive lacks the attribute
};

// One primitive instance: a primitive under one node, with its material resolved.
struct Draw {
    std::vector<Vert> verts;
    std::vector<uint32_t> tris; // 3 indices into verts per triangle
    std::array<float, 4> base_color{1, 1, 1, 1};
    std::array<float, 3> emissive{0, 0, 0};
    const DecodedTexture* texture = nullptr;
    AlphaMode alpha_mode = AlphaMode::opaque;
    float alpha_cutoff = 0.5f;
    bool double_sided = false;
    bool flip_winding = false; // the node's world matrix mirrors (negative determinant)
};

// Everything the pixel stage needs besides the draws.
struct Frame {
    int width = 0, height = 0; // output pixels
    int ssaa = 1;
    int subpixel_bits = 8;
    RenderMode mode = RenderMode::shaded;
    bool orthographic = false;
    double near_plane = 1, far_plane = 0; // far only matters for orthographic depth
    std::array<float, 3> light{0, 0, 1};    // normalized, view space
    float ambient = 0.25f;
    std::optional<std::array<float, 3>> background; // sRGB
};

struct RasterStats {
    size_t nan_triangles = 0, culled = 0;
    double setup_ms = 0, raster_ms = 0;
};

// Clips, culls, snaps and rasterizes the draws in order, filling out.color/depth (output resolution).
RasterStats rasterize(RenderResult& out, const std::vector<Draw>& draws, const Frame& frame);

// Colours.
std::array<float, 3> viridis(float t); // sRGB, t in [0,1]
// Draws the colour bar and its min/max labels at the right edge of an RGBA (straight alpha, raw) image.
void draw_legend(ImageF& image, float min_value, float max_value);
// Pixels the legend takes from the right edge (the default view frames the scene in the rest).
int legend_width(int image_height, float min_value, float max_value);

} // namespace furrow::render_detail
