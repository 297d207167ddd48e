// furrow::render — the verification rasterizer: renders a whole Scene to an in-memory image, exactly where
// exactness is checkable (fill rule, perspective-correct interpolation, near-plane clipping, depth order,
// MASK cutoff, culling), deterministically for any thread count. Also the image metrics that tests use.
//
// What it draws: every triangle primitive of the nodes reachable from Scene::roots (all parentless nodes if
// roots is empty), morph targets at their default weights (node weights, else mesh weights), skins in bind
// pose (joint world matrix × inverse bind matrix, linear blend). glTF material semantics: baseColorFactor ×
// baseColorTexture × COLOR_0, the texture sampled as a GPU samples it for a real-time viewer: sRGB-decoded,
// the sampler's magFilter and minFilter (mipmaps built like glGenerateMipmap, trilinear or nearest-level,
// level of detail from the screen-space UV derivatives per output pixel), wrap modes and texCoord set; an
// unset filter is three.js's default (LINEAR, LINEAR_MIPMAP_LINEAR). KHR_texture_transform and anisotropic
// filtering are not modelled; OPAQUE, MASK (alpha >= alphaCutoff is drawn opaque) and BLEND
// (drawn after opaque geometry, primitives sorted back to front, no depth write); doubleSided disables
// back-face culling and flips the normal of back faces; a node with a negative-determinant transform flips
// the winding. Lambert with one directional light plus ambient, emissive added. Primitives without normals
// are shaded flat. Points and lines are ignored. The alpha modes apply in every RenderMode; of two opaque
// surfaces at exactly the same depth, the one drawn first (scene order) wins.
//
// Time a frame by timing render_scene; RenderResult::timing splits it into stages (for `furrow bench`).
#pragma once

#include <furrow/mesh.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace furrow {

enum class RenderMode : int {
    shaded = 0, // material colour, Lambert lit; sRGB-encoded output
    normals,    // world-space normal as 0.5 + 0.5·n, unlit, written raw (no sRGB): n = 2·v − 1
    uv,         // TEXCOORD_0 as (u, v, 0), fractional part for values outside [0,1], raw (MASK/BLEND use the
                // factor and COLOR_0 alpha only: the texture is not sampled in this mode)
    depth,      // grey = 1 at the nearest visible depth .. 0.1 at the farthest, raw; exact values in .depth
    wireframe,  // shaded with the triangle edges drawn over it (clipping does not add edges)
    attribute,  // heat map (viridis) of a scalar CustomAttribute (its first component), with a legend
    cutoff,     // the front surface's alphaCutoff as a raw grey (MASK materials; 0 on OPAQUE and BLEND ones):
                // which alpha-tested layer shows, e.g. which fur shell (see cutoff_coverage)
};

// A camera. Unset eye/target frame the scene's bounding box: perspective looks from the front-right-above
// (a 3/4 view: +X, +Y, +Z of a Y-up scene) and backs off until every bounding-box corner is in view;
// orthographic looks straight down the up axis (top-down; for a Y-up scene +X is right and −Z is up in the
// image). In attribute mode the default framing leaves the legend's strip at the right edge free.
struct RenderCamera {
    std::optional<std::array<double, 3>> eye;
    std::optional<std::array<double, 3>> target; // default: the bounding-box centre
    std::array<double, 3> up{0, 1, 0};
    double fov_degrees = 45.0;  // vertical field of view, perspective only; (0, 180)
    bool orthographic = false;
    double ortho_height = 0.0;  // world units visible vertically (orthographic); 0 = fit the bounding box
    double near_plane = 0.0;    // distance of the near clipping plane; 0 = automatic (from the bounding box)
};

struct RenderOptions {
    int width = 1024, height = 768; // output pixels, each 1..16384
    RenderCamera camera;
    RenderMode mode = RenderMode::shaded;
    std::string attribute;          // RenderMode::attribute: CustomAttribute name, e.g. "_FUR_LENGTH"
    int ssaa = 1;                   // supersampling: ssaa × ssaa samples per pixel, box filtered; 1..8
    int subpixel_bits = 8;          // vertices snap to 1/2^bits of a sample before rasterizing: 8 as Direct3D
                                    // 10+ requires and desktop GPUs do; 4 as Vulkan's minimum and SwiftShader
                                    // (Chromium's software GL) do. Where alpha-tested fur is minified, it
                                    // decides which texel a pixel centre samples; 1..8
    std::optional<std::array<float, 3>> background; // sRGB in [0,1]; unset = transparent background
    std::array<float, 3> light_direction{-0.35f, 0.55f, 0.75f}; // towards the light, in view space
                                                                // (x right, y up, z towards the viewer)
    float ambient = 0.25f;          // Lambert: colour × (ambient + (1 − ambient)·max(0, n·l))
    bool legend = true;             // RenderMode::attribute: draw the colour bar with min/max values
    bool mipmaps = true;            // follow each sampler's minFilter, mip-mapping where it asks, as real-time
                                    // viewers do; false = sample the base level only (an offline renderer,
                                    // and the mip-free reference of the fur coverage measure)
};

struct RenderTiming { // wall-clock milliseconds per stage
    double vertices = 0; // morph, skin, transform (two passes: bounding box, then clip space)
    double setup = 0;    // clipping, culling, fixed-point snapping, binning
    double raster = 0;   // rasterize, shade, resolve the supersamples
    double total = 0;
};

struct RenderResult {
    // RGBA, width × height, straight (not premultiplied) alpha, in the encoding the PNG gets: the 8-bit
    // value is round(255·v). sRGB-encoded for shaded and wireframe, raw for the other modes.
    ImageF color;
    // 1 channel: distance along the view axis (eye space −z) of the nearest OPAQUE or MASK surface in the
    // pixel (minimum over its supersamples; BLEND surfaces do not write depth); +infinity where none.
    ImageF depth;
    std::vector<uint8_t> rgba8; // color quantized, width × height × 4 (what encode_png_rgba8 takes)
    std::vector<std::string> warnings; // each distinct problem once (a missing texture, an unknown sampler, ...)
    size_t triangles = 0;      // triangles submitted (after triangulation of the faces)
    size_t nan_triangles = 0;  // skipped because a vertex position was NaN or infinite (after transform)
    size_t culled = 0;         // back faces of single-sided materials
    float attribute_min = 0, attribute_max = 0; // RenderMode::attribute: the range the colours map
    RenderTiming timing;
};

// Renders the scene. Errors: size or ssaa out of range, fov out of (0,180) or non-finite camera values
// (invalid_argument); no triangle primitive or no finite vertex (invalid_input); an index out of range
// (invalid_input); RenderMode::attribute with an attribute no primitive has (invalid_argument).
// A texture whose image has no bytes or cannot be decoded is replaced by white, with a warning.
Status render_scene(RenderResult& out, const Scene& scene, const RenderOptions& options = {});

// Checks the options against their documented ranges (invalid_argument), as render_scene does first.
Status validate(const RenderOptions& options);

// ---------------------------------------------------------------------------------------------------------
// Image metrics for tests and tools. A size mismatch gives NaN (fails every comparison, so it is loud).
// ---------------------------------------------------------------------------------------------------------

// 1-channel mask: 1 where alpha (the last channel of an RGBA or grey+alpha image) > threshold, else 0.
ImageF silhouette_mask(const ImageF& image, float alpha_threshold = 0.5f);
// Number of mask pixels > 0.5.
size_t mask_area(const ImageF& mask);
// Intersection over union of two masks (pixels > 0.5); 1 when both are empty.
double mask_iou(const ImageF& a, const ImageF& b);
// Mean over all pixels and channels of |a − b|.
double mean_absolute_difference(const ImageF& a, const ImageF& b);
// Mean over the pixels where both images have alpha > 0.5 of |a − b| in the RGB channels (the colour
// difference on covered pixels); 0 when no pixel is covered in both.
double mean_covered_difference(const ImageF& a, const ImageF& b);

// Fur coverage, measured on a RenderMode::cutoff image (or a viewer's render of the same): `covered` is the
// fraction of the image's pixels where a MASK layer (a fur shell or fin) is in front, `height` the same
// weighted by the layer's cutoff (its height fraction in the fur). The ratio of either to the value of a
// supersampled render without mipmaps is the coverage a viewer keeps: a mip chain that thins the strands
// lowers `height` (upper shells vanish) and may raise `covered` (lower shells turn solid).
struct CutoffCoverage {
    double covered = 0, height = 0;
};
CutoffCoverage cutoff_coverage(const ImageF& cutoff_image);

} // namespace furrow
