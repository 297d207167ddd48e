// furrow::tessellate — adaptive, crack-free tessellation of subdivision surfaces (OpenSubdiv 3.5 Bfr).
//
// A polygon mesh (plain arrays) is welded by position, repaired where OpenSubdiv would misbehave, and the limit
// surface of its Catmull-Clark, Loop or bilinear subdivision is tessellated into triangles:
//   - every edge of the welded mesh gets ONE integer rate (segments along it), computed once from the criteria
//     below; points on shared vertices and edges are evaluated once and used by every face around them, so
//     the output is watertight wherever the input is, for any mix of rates;
//   - UVs and other attributes form a face-varying channel: positions stay shared across UV seams, and
//     vertices are split only where attribute values (or normals across a crease) really differ;
//   - the output is deterministic: the same bytes for any thread count (TBB).
// Input problems OpenSubdiv cannot take (degenerate faces, faces oriented against their neighbours, edges with
// more than two faces) are repaired or tessellated linearly (the faces keep their corners and are shared with their neighbours, so still no
// crack), and reported in TessellateStats; SurfaceOptions::refuse_bad_topology turns them into an error.
// Interior vertices of valence 2 are evaluated on the limit surface like any other (their faces bypass the
// surface cache, which OpenSubdiv 3.5.0 may share wrongly there: PR 1353).
//
// Terrain seen from a camera, in one call (the scene's triangle primitives are replaced, all else is kept):
//     furrow::TessellateOptions o;
//     o.surface.scheme = furrow::SubdivisionScheme::bilinear;     // keep the terrain's shape
//     o.rates.camera = furrow::TessellationCamera{{0, 2, -10}};   // eye in world space
//     o.rates.pixel_error = 4;                                    // segments of at most 4 px
//     furrow::Status s = furrow::tessellate_scene(scene, o);
#pragma once

#include <furrow/mesh.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace furrow {

enum class SubdivisionScheme : int { catmark = 0, loop, bilinear }; // loop needs triangles only
// How the limit surface treats open boundaries. (OpenSubdiv's own default, no boundary, drops boundary faces.)
enum class BoundaryInterpolation : int { edge_only = 0, edge_and_corner };
// Face-varying rule for UVs and the other attributes (Sdc::Options::FVarLinearInterpolation): from smooth
// everywhere to linear everywhere (the UV layout kept exactly, as a texture painter expects).
enum class UvInterpolation : int { smooth = 0, corners_only, corners_plus1, corners_plus2, boundaries, linear };

struct SurfaceOptions {
    SubdivisionScheme scheme = SubdivisionScheme::catmark;
    BoundaryInterpolation boundary = BoundaryInterpolation::edge_and_corner;
    UvInterpolation uv_interpolation = UvInterpolation::corners_only;
    double crease_angle_degrees = 180.0; // edges whose faces' normals differ by more become infinitely sharp
                                         // creases with split normals; 180 = no creases
    int accuracy = 2;                    // refinement levels used near extraordinary vertices, 1..10
                                         // (Bfr approximation level; the error falls about 8x per level)
    double weld_tolerance = 0.0;         // absolute; 0 = weld bit-identical positions only
    bool refuse_bad_topology = false;    // true: repairable input problems are an invalid_input error
};

// A viewer: the eye in world space and the projection that turns lengths into pixels. Points are measured by
// their Euclidean distance to the eye (not view depth), so what is behind or beside the camera is diced like
// what is in front: turning the camera needs no new tessellation, and an eye inside the mesh is well defined.
struct TessellationCamera {
    std::array<double, 3> eye{0, 0, 0};
    double fov_degrees = 45.0;  // vertical field of view, (0, 180)
    int viewport_height = 1080; // pixels
};

struct FocusPoint {
    std::array<double, 3> centre{0, 0, 0}; // world space
    double radius = 1.0;                   // full rate within radius, falling linearly to 1 at 2 × radius
    int rate = 0;                          // 0 = RateOptions::max_rate
};

// Criteria: the rate of an edge is the largest any enabled criterion asks for, then capped at max_rate.
struct RateOptions {
    int uniform = 0;                          // > 0: every edge at least this rate
    std::optional<TessellationCamera> camera; // required by distance, pixel_error and screen_error
    bool distance = false;                    // Unity's distance-based factor (the seed): per vertex
    double near = 1.0, far = 10.0;            //   clamp(1 - (d - near)/(far - near), 0.01, 1) · max_rate,
                                              //   an edge takes the mean of its ends; near < far required
    double pixel_error = 0.0;  // > 0: projected segments of at most this many pixels (Cycles' dicing rate)
    double screen_error = 0.0; // > 0: chordal error to the limit surface of at most this many pixels on screen
    double max_error = 0.0;    // > 0: chordal error to the limit surface of at most this (world units)
                               // (both estimated from second derivatives, then measured per face as
                               // Tessellator::measure does and raised where needed; capped by max_rate)
    std::vector<FocusPoint> focus;
    // Hooks for callers with their own detail measure (e.g. a heightmap): a wanted rate per input vertex (an
    // edge takes the larger of its ends), and/or a callback given the edge's two control points (object
    // space). The callback is called concurrently from several threads; return <= 0 for "no opinion".
    const float* vertex_rates = nullptr;
    std::function<double(const float* p0, const float* p1)> edge_rate;
    int max_rate = 64;            // 1..32767
    size_t max_triangles = 0;     // > 0: every rate is scaled down until the output fits; error if even
                                  // rate 1 does not
    // World matrices (column-major) of the places the mesh is drawn; view and world-size criteria take the
    // most demanding one. Empty = object space is world space.
    std::vector<std::array<double, 16>> instances;
};

struct TessellateOptions {
    SurfaceOptions surface;
    RateOptions rates;
    // Scene level: > 0 (and rates.max_triangles == 0): when the rates would make more triangles than this,
    // tessellate_scene refuses (invalid_argument, naming the estimate) before evaluating any surface, so a
    // too-fine criterion fails in seconds instead of writing gigabytes. `furrow tessellate` sets 20,000,000.
    size_t triangle_budget = 0;
    bool keep_parameters = false; // fill TessellateOutput::triangle_patches/_coords (for Tessellator::measure)
};

// ---------------------------------------------------------------------------------------------------------
// Plain arrays in, triangles out.
// ---------------------------------------------------------------------------------------------------------
struct AttributeArray {
    const float* values = nullptr; // components per input vertex
    int components = 1;            // 1..16
};

struct TessellateInput {
    const float* positions = nullptr; // xyz per vertex
    size_t vertex_count = 0;
    const uint32_t* indices = nullptr; // face corners, counter-clockwise seen from outside
    size_t index_count = 0;
    const uint32_t* face_sizes = nullptr; // corners per face; nullptr = every face is a triangle
    size_t face_count = 0;                // with face_sizes
    const uint32_t* face_groups = nullptr; // optional group per face (e.g. a primitive): attribute values are
                                           // never shared across groups, the surface stays smooth across
    const float* uvs = nullptr;            // optional, 2 per vertex: the face-varying channel
    std::vector<AttributeArray> attributes;  // more per-vertex values interpolated like the UVs (colours, ...)
    std::vector<AttributeArray> vertex_data; // per-vertex values interpolated like positions (morph deltas)
    const uint16_t* joints = nullptr;        // optional skin, 4 joints + 4 weights per vertex: interpolated
    const float* weights = nullptr;          // linearly, then the 4 largest kept and renormalised
};

struct TessellateStats {
    size_t input_faces = 0, faces = 0;     // faces after repair (n-gons with a repeated vertex are split)
    size_t dropped_faces = 0;              // degenerate: fewer than 3 distinct welded corners
    size_t flipped_faces = 0;              // reversed to agree with the orientation of their neighbours
    size_t linear_faces = 0;               // tessellated linearly (fallback) ...
    size_t non_manifold_edges = 0;         // ... because of these (more than two faces)
    size_t inconsistent_edges = 0;         // ... or these (both faces traverse the edge the same way, on a
                                           //     non-orientable part)
    size_t valence2_vertices = 0;          // interior vertices of valence 2 (on the limit surface: not a fallback)
    size_t failed_faces = 0;               // ... or OpenSubdiv found no limit surface
    size_t split_vertices = 0;             // non-manifold (bowtie) vertices split into one point per fan
    size_t crease_edges = 0;
    size_t edges = 0;
    int min_rate = 0, max_rate = 0;
    double mean_rate = 0.0;
    double rate_scale = 1.0; // < 1 when max_triangles scaled the rates down
    size_t vertices = 0, triangles = 0;
    double prepare_seconds = 0, rate_seconds = 0, evaluate_seconds = 0;
    std::vector<std::string> warnings;
};

struct TessellateOutput {
    std::vector<float> positions;                 // xyz
    std::vector<float> normals;                   // xyz, unit, from the surface's derivatives
    std::vector<float> uvs;                       // 2 per vertex if the input had UVs
    std::vector<std::vector<float>> attributes;   // as TessellateInput::attributes
    std::vector<std::vector<float>> vertex_data;  // as TessellateInput::vertex_data
    std::vector<uint16_t> joints;                 // 4 per vertex if the input had a skin
    std::vector<float> weights;
    std::vector<uint32_t> indices;                // triangles, oriented like their input faces
    std::vector<uint32_t> triangle_faces;         // input face of each triangle
    std::vector<uint32_t> triangle_patches;       // keep_parameters: internal face of each triangle, and
    std::vector<float> triangle_coords;           //   (u, v) of its 3 corners in that face's parameterisation
    TessellateStats stats;
};

// One call: prepare + tessellate.
Status tessellate(TessellateOutput& out, const TessellateInput& in, const TessellateOptions& options = {});

struct EdgeRate {
    uint32_t v0 = 0, v1 = 0; // input vertices at its ends (the lowest index of each welded position)
    int rate = 1;
};

// Chordal error of a tessellation against the limit surface, sampled at each triangle's centroid and edge
// midpoints and compared with the limit surface at the same parametric location. Linear (fallback) faces
// are not sampled.
struct ErrorReport {
    size_t samples = 0;
    double max_error = 0, mean_error = 0; // world units (the most demanding instance)
    double diagonal = 0;                  // of the world bounding box of the input
    double max_pixels = 0;                // with a camera: chordal error x focal length / distance to the eye
    double mean_pixels = 0;
};

// The prepared mesh, for tessellating it again and again (a moving camera, a benchmark sweep): topology
// repair, the OpenSubdiv refiner and surface factory are built once. Thread-safe for concurrent const use.
class Tessellator {
public:
    Tessellator();
    ~Tessellator();
    Tessellator(Tessellator&&) noexcept;
    Tessellator& operator=(Tessellator&&) noexcept;

    // Copies what it needs from `in`. Errors: malformed input (invalid_input), loop with non-triangles
    // (unsupported), options out of range (invalid_argument).
    Status prepare(const TessellateInput& in, const SurfaceOptions& options = {});
    Status tessellate(TessellateOutput& out, const RateOptions& rates, bool keep_parameters = false) const;
    // The rate every edge would get, without tessellating.
    Status edge_rates(std::vector<EdgeRate>& out, const RateOptions& rates) const;
    // Triangles the rates would produce (after max_triangles scaling).
    Status count_triangles(size_t& out, const RateOptions& rates) const;
    // Needs an output made by this Tessellator with keep_parameters.
    Status measure(ErrorReport& out, const TessellateOutput& tessellation, const RateOptions& view = {}) const;
    const TessellateStats& topology() const; // the repair counters of prepare()

    struct Impl;

private:
    std::unique_ptr<Impl> impl_;
};

// ---------------------------------------------------------------------------------------------------------
// Scene level (`furrow tessellate`): every mesh's triangle-mode primitives are tessellated together (so
// that primitives sharing a border do not crack), each primitive keeping its material; camera and focus are
// in world space, a mesh drawn by several nodes takes the most demanding view. Normals come from the surface,
// UVs/colours/custom attributes are face-varying, skins are interpolated and renormalised to the top 4, morph
// targets follow the surface; tangents are dropped (a warning says so). Everything else is kept.
// max_triangles applies to the whole scene.
// ---------------------------------------------------------------------------------------------------------
struct SceneTessellateReport {
    size_t meshes = 0, primitives = 0;
    size_t triangles_in = 0, triangles_out = 0;
    TessellateStats totals; // counters summed over meshes; rates: min/max over meshes
    std::vector<std::string> warnings;
};
Status tessellate_scene(Scene& scene, const TessellateOptions& options, SceneTessellateReport* report = nullptr);

} // namespace furrow
