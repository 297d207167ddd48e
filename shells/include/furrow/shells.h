// furrow::shells — fur shells (Lengyel, Praun, Finkelstein, Hoppe, "Real-Time Fur over Arbitrary Surfaces",
// I3D 2001) grown offline from a base mesh: N copies of the surface offset along a crack-free extrusion
// direction, each showing one slice of a strand volume through an alpha-tested strand texture, plus optional
// fins (quads standing on the edges) and LOD levels.
//
// Two levels of API:
//   - plain arrays: compute_shell_frame() gives every vertex its extrusion direction and fur length (welded,
//     clamped so that no shell intersects the base or another shell), shell_positions() places one shell;
//   - a Scene: add_fur_shells() does the whole job on every triangle primitive of a loaded glTF/OBJ scene
//     (mask, comb, colours, strand textures, materials, fins, LOD, skins and morph targets) and is what
//     `furrow shells` runs. The demo recipe:
//         furrow::FurOptions o;
//         o.shells.layers = 32;  o.shells.length = 0.04;           // world units (metres for the creature)
//         furrow::load_png(o.mask, "models/creature_fur_mask.png"); // optional
//         furrow::FurReport report;
//         furrow::Status s = furrow::add_fur_shells(scene, o, &report); // then render_scene(scene) as usual
//
// Every function is deterministic: the same input gives the same bytes for any thread count (TBB).
#pragma once

#include <furrow/mesh.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace furrow {

// ---------------------------------------------------------------------------------------------------------
// Shell geometry on plain arrays (object space)
// ---------------------------------------------------------------------------------------------------------

struct ShellOptions {
    int layers = 16;              // N shells, 1..256; shell i = 1..N sits at height fraction s(i/N)
    double length = 0.05;         // L: full fur length (object units here; world units in FurOptions)
    double spacing_power = 1.0;   // s(t) = t^p; 1 = evenly spaced, > 1 packs shells near the skin; 0.1..10
    double droop = 0.0;           // gravity bends the strands, keeping their length: the tip turns toward
                                  // gravity's direction along the surface by droop·17.5° (× the share of gravity
                                  // along the surface), the bend growing toward the tip; 4 hangs a vertical
                                  // wall's tips down, 20° short of its plane (shells cannot show more); 0..4
    std::array<double, 3> gravity{0, -1, 0}; // droop direction (object space here; world space in FurOptions)
    double comb_strength = 1.0;   // lean of the tip per unit comb vector, as a fraction of the strand length
    int lod_levels = 1;           // LOD levels the layer heights must be safe for (N, N/2, N/4, ...); 1..8

    // Robustness (why: see shell_frame.cpp). Defaults are what `furrow shells` uses.
    double max_even_thickness = 2.0; // cap of the even-thickness factor (1 at convex vertices, 1/cos at creases)
    bool feature_clamp = true;       // rays and medial-axis test (CGAL AABB tree): keep each offset within
    double safe_fraction = 0.45;     // ... this fraction of the free distance, so two facing surfaces never meet
    double min_area_ratio = 0.25;    // no-fold limit: every offset triangle keeps at least this fraction of
                                     // its base area (measured along the base normal), at every layer
};

// Per-vertex fur frame. Every array has one entry (or xyz triple) per input vertex; split copies of one
// position (UV seams, hard edges) hold bit-identical values, which is what keeps the shells crack-free.
struct ShellFrame {
    std::vector<float> direction; // xyz, unit extrusion direction (angle-weighted pseudo-normal); 0 if none
    std::vector<float> length;    // H: fur length after mask and clamps (0 = bald)
    std::vector<float> requested; // L·mask: the offset distance asked for (H differs by even thickness/clamps)
    std::vector<float> lean;      // xyz, tip displacement along the surface from the comb, per unit H
    std::vector<float> sag;       // xyz, droop: the tip's bend angle (radians) × the unit direction of gravity
                                  // along the surface; the strand bends along a curve of its own length
    std::vector<uint8_t> flags;   // ShellClamp bits
    size_t welded_vertices = 0;   // unique positions
    size_t clamped_vertices = 0;  // unique positions whose length was reduced by any clamp below
    size_t clamped_by_ray = 0, clamped_by_fold = 0, clamped_by_even_cap = 0;
    size_t bald_vertices = 0;     // unique positions with length 0 (mask 0, no direction, clamped to 0)
};
enum ShellClamp : uint8_t {
    clamp_ray = 1,       // free space: a ray hit within length / safe_fraction, or the offset would cross
                         // the medial axis (get nearer to another part of the surface than to its own)
    clamp_fold = 2,      // an offset triangle would fold over or sweep through the next shell (concave edges
                         // and corners), or the outermost shell was found crossing itself or the base (exact
                         // predicates) and the fur there was shortened until it no longer does
    clamp_even_cap = 4,  // the 1/cos factor hit max_even_thickness (a very sharp corner)
    clamp_no_normal = 8, // no valid incident face: no direction, no fur
};

// Checks every option against its documented range (invalid_argument, naming the option), as
// compute_shell_frame does first.
Status validate(const ShellOptions& options);

// Triangles as 3 indices each. mask (optional): one value in [0,1] per vertex, copies of one position are
// reconciled by taking their maximum (a seam never shortens the furrier side). comb (optional): one
// object-space xyz lean per vertex (its part along the surface is used), copies averaged. Errors: sizes,
// indices out of range, options out of range (invalid_argument).
Status compute_shell_frame(ShellFrame& out, const float* positions, size_t vertex_count, const uint32_t* indices,
                           size_t index_count, const float* mask, const float* comb, const ShellOptions& options);

// Height fraction s(i/N) of shell `layer` (1..layers).
double shell_height_fraction(int layer, int layers, double spacing_power);

// Positions of shell `layer` of `layers`: p + H·(A(s)·direction + B(s)·ĝ + s·lean), s its height fraction:
// the point at arc length H·s of the strand that starts along `direction` and bends toward ĝ = sag/|sag| by
// the angle |sag|·u² at arc fraction u (A, B: the integrals of its cosine and sine).
void shell_positions(float* out, const ShellFrame& frame, const float* positions, size_t vertex_count, int layer,
                     int layers, double spacing_power);

// The same positions from plain per-vertex arrays, as the instanced layout stores them (ShellLayout::instanced:
// roots = POSITION, direction = _FUR_DIRECTION, length = _FUR_LENGTH, lean = _FUR_LEAN, sag = _FUR_SAG; lean or
// sag null = zero): the C++ reference of the vertex shader in README "Instanced layout". Computed in double
// from the float inputs, so it gives the engine layout's shell `layer` bit for bit.
void instanced_shell_positions(float* out, const float* roots, const float* direction, const float* length, const float* lean,
                               const float* sag, size_t vertex_count, int layer, int layers, double spacing_power);

// Distance from each point to the nearest point of a triangle mesh (CGAL AABB tree), in double: what the
// benchmark uses to measure the achieved offset. Writes point_count values.
void distances_to_mesh(double* out, const float* points, size_t point_count, const float* positions,
                       size_t vertex_count, const uint32_t* indices, size_t index_count);

// ---------------------------------------------------------------------------------------------------------
// Strand textures
// ---------------------------------------------------------------------------------------------------------
struct StrandTextureOptions {
    int size = 256;              // square, tiling, 16..4096 pixels
    int strands = 1400;          // strands per tile
    double radius = 2.2;         // strand root radius in pixels
    double min_height = 0.55;    // strand heights are uniform in [min_height, 1]
    uint64_t seed = 1;
};
// Density texture, RGBA8 (size × size × 4): alpha = height fraction at which a strand passing through the
// texel ends (tapered: a cone, full height on the axis texel), 0 between strands, so a shell with alpha
// cutoff c shows exactly the strands' cross-section at height c; rgb = per-strand brightness (multiplies
// COLOR_0). add_fur_shells gives shell i of N the cutoff s((i − 1/2)/N): mid-way through its slab.
// Tiles seamlessly (distances wrap around).
std::vector<uint8_t> make_strand_texture(const StrandTextureOptions& options);
// Fin texture, RGBA8 (size × size/2 × 4): a side view of strands, roots at the bottom row, tips at the top;
// alpha 1 on a strand, 0 elsewhere.
std::vector<uint8_t> make_fin_texture(const StrandTextureOptions& options);

// ---------------------------------------------------------------------------------------------------------
// Whole scenes
// ---------------------------------------------------------------------------------------------------------
enum class ShellLayout : int {
    viewer = 0, // one primitive per shell with its own MASK material (rising alphaCutoff), density texture on
                // TEXCOORD_1, COLOR_0 = base albedo darkened toward the roots: any glTF viewer shows fur
    engine = 1, // one primitive holding all shells with _FUR_LAYER (height fraction), _FUR_LENGTH (H, object
                // units) and _FUR_DIRECTION (unit xyz) for an engine's own shader; one MASK material
    instanced = 2, // no copies: per furred mesh, one "shell base" mesh (the kept base triangles once, COLOR_0 =
                   // albedo, _FUR_DIRECTION, _FUR_LENGTH, and _FUR_LEAN/_FUR_SAG when comb/droop are not
                   // zero) on a node "<node>_fur_shells" outside the default scene, which an engine draws N times
                   // extruding in its vertex shader (instanced_shell_positions); the layer heights, cutoffs, root
                   // shade and strand material in the mesh's extras "FURROW_shells" (README "Instanced layout").
                   // Stock viewers show the base model; the source meshes get only the fins
};
// Both layouts give the strand and fin textures a non-mipmapped sampler (minFilter LINEAR): a box-filtered
// mip chain averages each strand with the gaps around it, so at a distance the upper shells fail their alpha
// test and vanish while the lowest turn solid. An engine that wants mipmaps for these textures must build
// them itself so that alpha-tested coverage survives (I. Castaño, "Computing Alpha Mipmaps", 2010: rescale
// each level's alpha until the fraction of texels above the cutoff matches the base level; with one cutoff
// per shell, match the whole alpha distribution), or draw the shells with alpha to coverage.

struct FurOptions {
    ShellOptions shells;        // length in world units (converted per mesh by its node's scale); gravity in
                                // world space (glTF: y up)
    ImageF mask;                // empty = fur everywhere; sampled bilinearly (REPEAT) at TEXCOORD_0
    int mask_channel = 0;       // 0..channels-1 of `mask`
    ImageF comb;                // empty = none; like a flow map: r = lean along +u, g = lean "up" the image
                                // (−v), each 2·value − 1; sampled at TEXCOORD_0
    ShellLayout layout = ShellLayout::viewer;
    bool fins = false;          // one quad per manifold edge, MASK fin material, _FUR_FIN_NORMAL for fading
    StrandTextureOptions strands;
    double tile_size = 0;       // world size of one strand-texture tile; 0 = 4 × length
    double root_shade = 0.45;   // COLOR_0 = albedo × (root_shade + (1 − root_shade) × height fraction)
    bool keep_frames = false;   // return each primitive's ShellFrame in FurReport::frames (for measurements)
    bool refine_starved = true; // split base triangles whose corners the clamps starve (coarse faces at concave
                                // corners: a shelf whose corners all meet walls), so fur grows inside them;
                                // the base surface and its shading do not change (FurReport::refined_faces)
    size_t refine_budget = 4096; // refinement makes a primitive of T triangles at most 8·T + this many (and
                                 // never more than max_triangles leaves room for)
    double refine_tolerance = 1e-3; // refinement has converged (each of its rounds regrows the primitive's whole
                                 // frame) once two rounds in a row change the share of the fur asked that grows
                                 // (min(1, length / asked), area-weighted over the furred triangles) by less than
                                 // this; 0 = refine until no triangle is marked (at most 16 rounds); 0..1
    double lod_simplify_error = 0; // > 0: LOD level k >= 1 grows on the base simplified (meshopt_simplify, UV
                                // seams and borders kept) toward 1/4^k of its triangles, within a relative error
                                // of this × 2^(k−1) (fraction of the mesh's largest extent, as meshopt defines
                                // it; e.g. 0.01: 1 % at level 1, 2 % at level 2), checked on the sampled distance
                                // between the two surfaces both ways (meshopt asked again with half the error until
                                // it holds: its own quadric error can understate it); 0 = off (every level on the full
                                // base); 0..1. Instanced layout: level k's simplified base is its own mesh
                                // "<mesh>_fur_shells_lod<k>", named by FURROW_shells.levels[k].mesh.
                                // The clamps were computed on the full base: a simplified level may cut corners
                                // by up to its error.
    size_t max_triangles = 0;   // > 0: refuse (invalid_argument), before anything is grown, when the shells,
                                // fins and LOD levels could add more triangles than this (base triangles ×
                                // shells of every level, + 6 per triangle and level with fins); `furrow shells`
                                // sets 20,000,000. Refinement only grows the base within what is left.
};

struct FurFrame {
    size_t mesh = 0, primitive = 0; // the base primitive
    double length = 0;              // L in the mesh's object units
    std::vector<uint32_t> triangles; // its faces as triangles (n-gons fanned)
    ShellFrame frame;
};

struct FurReport {
    size_t primitives = 0;          // base primitives that got fur
    size_t base_triangles = 0;
    size_t shell_primitives = 0;    // glTF primitives added (shells, fins, all LOD levels)
    size_t shell_triangles = 0;     // triangles added (shells and fins, all LOD levels)
    size_t dropped_triangles = 0;   // per-shell triangles left out because all three corners are bald,
                                    // summed over shells and LOD levels
    size_t fin_quads = 0;
    size_t welded_vertices = 0;
    size_t clamped_vertices = 0, clamped_by_ray = 0, clamped_by_fold = 0, clamped_by_even_cap = 0;
    size_t bald_vertices = 0;
    size_t refined_faces = 0;       // base triangles bisected so that fur grows inside coarse faces whose
                                    // corners are clamped (the base primitive is replaced by its refinement)
    size_t refine_rounds = 0;       // that refinement's rounds, summed over the primitives: each regrew its
                                    // primitive's whole frame (most of a coarse mesh's set-up)
    std::vector<size_t> lod_base_triangles; // per LOD level 0..K-1: base triangles its shells grow on (level 0:
                                            // base_triangles; fewer with lod_simplify_error)
    std::vector<double> lod_simplify_error; // per LOD level: meshopt's result error, relative to the extent of
                                            // the mesh (the largest over the primitives; 0 at level 0 or when off)
    std::vector<int> lod_nodes;     // LOD level k >= 1: node index (outside the default scene), per source node
    std::vector<int> shell_nodes;   // instanced layout: the shell base's node (outside the default scene),
                                    // per furred mesh
    std::vector<FurFrame> frames;   // with FurOptions::keep_frames
    std::vector<std::string> warnings;
    // Wall time of the two stages, for benchmarks: setup = everything done once per base primitive (frames
    // with their clamps and intersection test, vertex sets, albedo, strand textures); emit = building and
    // attaching the shell, fin and LOD primitives (grows with the number of shells).
    double setup_seconds = 0, emit_seconds = 0;
};

// Grows fur on every triangle primitive of every mesh reached from a node. The base primitives stay as they
// are (the opaque skin); shells (and fins) are appended to the same mesh, so they follow the node, its skin
// (JOINTS_0/WEIGHTS_0 copied) and morph targets (position and normal deltas copied). LOD levels 1..K-1 go
// into new meshes on new nodes outside the default scene (a viewer shows level 0; an engine picks a level by
// node name "<node>_fur_lod<k>"). Errors (invalid_argument): options out of range, a mask or comb with no
// TEXCOORD_0 to sample it at, a mask channel the image lacks; (invalid_input): no triangle to grow fur on, a
// triangle corner with a NaN or infinite position.
Status add_fur_shells(Scene& scene, const FurOptions& options, FurReport* report = nullptr);

// Checks the options add_fur_shells checks first: ShellOptions, the tile size, root shade, mask and comb
// images (invalid_argument).
Status validate(const FurOptions& options);

} // namespace furrow
