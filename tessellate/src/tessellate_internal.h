// Internal types of furrow::tessellate: the prepared (welded, repaired, classified) mesh shared by the rate
// criteria, the evaluation and the error measure. OpenSubdiv types stay in this folder.
#pragma once

#include <furrow/tessellate.h>
#include <furrow_kernel/affine.h>

#include <opensubdiv/bfr/parameterization.h>
#include <opensubdiv/bfr/refinerSurfaceFactory.h>
#include <opensubdiv/bfr/surface.h>
#include <opensubdiv/bfr/surfaceFactoryCache.h>
#include <opensubdiv/far/topologyRefiner.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <mutex>
#include <shared_mutex>
#include <vector>

namespace furrow::tessellate_detail {

namespace osd = OpenSubdiv;

using ThreadedCache = osd::Bfr::SurfaceFactoryCacheThreaded<std::shared_mutex, std::shared_lock<std::shared_mutex>,
                                                            std::unique_lock<std::shared_mutex>>;
using SurfaceFactory = osd::Bfr::RefinerSurfaceFactory<ThreadedCache>;
using Surface = osd::Bfr::Surface<float>;

constexpr uint32_t none = 0xffffffffu;

// Vocabulary: a *corner* is one (face, position in face) slot, numbered globally; a *point* is a shared
// tessellation point at a base vertex (one per welded position and edge-connected fan of faces); a *side* is
// one face's use of an edge; a *group* is one output vertex at a point (points split by attribute value and
// normal sector); a *value* is one distinct attribute vector at a welded position (per face group).
struct PreparedMesh {
    SurfaceOptions options;
    osd::Sdc::SchemeType scheme = osd::Sdc::SCHEME_CATMARK;

    // Per welded position: W floats (xyz, then the vertex_data arrays) taken from its lowest input vertex.
    int W = 3;
    std::vector<float> welded_data;
    std::vector<uint32_t> welded_input; // the lowest input vertex of each welded position
    size_t input_vertex_count = 0;
    std::vector<int> vertex_data_components;

    // Faces after repair: corners [face_offset[f], face_offset[f+1]).
    std::vector<uint32_t> face_offset;
    std::vector<uint32_t> face_source; // input face index
    std::vector<uint8_t> face_linear;  // 1: tessellated linearly (fallback)
    std::vector<uint8_t> face_uncached; // 1: at an interior valence-2 vertex: surfaces from factory_uncached
    std::vector<uint8_t> face_regular;  // 1: its limit surface is one regular B-spline patch (Bfr IsRegular)
    std::vector<uint8_t> face_regular_interior; // 1: regular and without boundary (regular_interior): its patch
                                                // points are its 16 control points, kept in regular_control
    std::vector<uint32_t> regular_control;      // 16 refiner vertices per face (set for regular interior faces)
    std::vector<int> face_refiner;     // face index in the refiner, -1 for faces left out of it
    std::vector<uint32_t> corner_input, corner_welded, corner_point, corner_value, corner_group;
    std::vector<uint32_t> corner_edge, corner_side; // the edge that starts at the corner, and this face's side
    std::vector<uint32_t> corner_face;

    // Points.
    std::vector<uint32_t> point_welded;
    std::vector<uint32_t> point_owner;       // corner that evaluates the point (smooth faces preferred)
    std::vector<uint32_t> point_group_begin; // groups of point p: [begin[p], begin[p+1])

    // Groups (output vertices at points), sorted by (point, value, sector).
    std::vector<uint32_t> group_point;
    std::vector<uint32_t> group_value;
    std::vector<uint32_t> group_sector;     // index into sector_begin
    std::vector<uint32_t> group_attr_owner; // corner that evaluates the attribute values of this group
    std::vector<uint32_t> group_attr_end;   // groups [g, end) share (point, value): written together
    std::vector<uint32_t> sector_begin;     // corners of sector s: sector_corners[begin[s] .. begin[s+1])
    std::vector<uint32_t> sector_corners;
    std::vector<uint32_t> sector_normal_owner; // a sector of regular smooth faces only: the one corner whose
                                               // face's normal there serves the whole sector; none: every
                                               // corner's normal, averaged

    // Edges between points (a < b), with their sides in face order.
    std::vector<std::array<uint32_t, 2>> edges;
    std::vector<uint32_t> edge_side_begin; // sides of e: [begin[e], begin[e+1])
    std::vector<uint32_t> side_corner;     // the corner whose outgoing edge this is
    std::vector<uint32_t> edge_owner;      // side that evaluates the shared points
    std::vector<uint8_t> edge_split;       // bit 0: attributes differ per side (seam); bit 1: normals differ
                                           // per side (crease, non-manifold); any bit: one vertex set per side
    std::vector<uint8_t> edge_crease;      // dihedral angle above SurfaceOptions::crease_angle_degrees
    std::vector<uint8_t> edge_normal_shared; // 1: regular smooth faces on both sides, no crease: the owner
                                             // side's normals serve every side (the others skip the evaluation)

    // Attribute values: K floats each (uvs first, then the attribute arrays), skin in 4 + 4.
    int K = 0;
    bool has_uv = false, has_skin = false;
    std::vector<int> attribute_components;
    std::vector<float> value_attrs;
    std::vector<uint16_t> value_joints;
    std::vector<float> value_weights;

    // OpenSubdiv: refiner over the smooth faces, its vertex data and face-varying values.
    std::vector<uint32_t> corner_refiner_vertex; // none for faces left out of the refiner
    std::vector<uint32_t> refiner_vertex_welded;
    std::unique_ptr<osd::Far::TopologyRefiner> refiner;
    std::unique_ptr<SurfaceFactory> factory;
    std::unique_ptr<SurfaceFactory> factory_uncached; // the same without a cache (OpenSubdiv 3.5.0, PR 1353)
    const SurfaceFactory& factory_of(size_t f) const { return face_uncached[f] ? *factory_uncached : *factory; }
    std::vector<float> refiner_data;  // W per refiner vertex
    std::vector<float> refiner_fvar;  // K per refiner face-varying value

    std::array<double, 3> bbox_min{0, 0, 0}, bbox_max{0, 0, 0};
    TessellateStats stats;

    size_t face_count() const { return face_source.size(); }
    uint32_t face_size(size_t f) const { return face_offset[f + 1] - face_offset[f]; }
    uint32_t next_corner(uint32_t c) const {
        uint32_t f = corner_face[c];
        return c + 1 == face_offset[f + 1] ? face_offset[f] : c + 1;
    }
    bool smooth(size_t f) const { return !face_linear[f]; }
    osd::Bfr::Parameterization parameterization(size_t f) const {
        return osd::Bfr::Parameterization(scheme, int(face_size(f)));
    }
};

// prepare_mesh.cpp: validation, weld, repair, classification (everything but OpenSubdiv).
Status prepare_mesh(PreparedMesh& m, const TessellateInput& in, const SurfaceOptions& options);
// The SurfaceOptions checks of prepare_mesh on their own (tessellate_scene runs them even when no mesh has
// anything to tessellate).
Status check_surface_options(const SurfaceOptions& options);
// build_surfaces.cpp: the refiner and the Bfr factory over the smooth faces; faces without a limit surface
// become linear. Then owners are chosen (they depend on which faces are smooth).
Status build_surfaces(PreparedMesh& m);
void choose_owners(PreparedMesh& m);
// True if the surface is a regular B-spline patch (16 control points) with no boundary.
constexpr int regular_points = 16;
bool regular_interior(const Surface& s, const osd::Bfr::Parameterization& param);

// edge_rates.cpp: real-valued rate wanted per edge (before scale, rounding and cap).
Status validate_rates(const RateOptions& r);
Status wanted_rates(std::vector<double>& out, const PreparedMesh& m, const RateOptions& r);
inline int final_rate(double wanted, double scale, int max_rate) {
    double r = std::ceil(wanted * scale - 1e-9);
    if (!(r >= 1.0)) return 1; // also NaN
    return r > double(max_rate) ? max_rate : int(r);
}
size_t count_triangles(const PreparedMesh& m, const std::vector<int>& rates);
// The rates handed to Bfr::Tessellation for face f: its N edge rates, then explicit inner rates (quads: the
// larger of each pair of opposite edges; other faces: the largest edge). Bfr would infer the mean, which
// leaves the interior coarser than the most demanding edge asked for. Face-local, so no crack can follow.
// Returns the number of rates written to out (N + 2 for quads, N + 1 otherwise).
int face_rates(const PreparedMesh& m, size_t f, const std::vector<int>& edge_rates, std::vector<int>& out);

// evaluate_tessellation.cpp
Status evaluate_tessellation(TessellateOutput& out, const PreparedMesh& m, const std::vector<int>& rates,
                             bool keep_parameters);

// measure_error.cpp
Status measure_tessellation(ErrorReport& out, const PreparedMesh& m, const TessellateOutput& t, const RateOptions& view);

// patch_param.cpp: the parametric layout of a face (Bfr's conventions) seen as a linear patch.
// Weights of the face's corners at (u, v) for the linear (bilinear / barycentric) interpolation.
void linear_weights(const osd::Bfr::Parameterization& p, const float uv[2], float* weights /* N */);
// Newell normal of a polygon given its corner positions (xyz, stride 3 floats), not normalised.
std::array<double, 3> newell_normal(const float* const* corners, size_t n);
// For measuring: maps the corners of one tessellation triangle into one chart (sub-faces of n-gons are
// separate tiles in Bfr's parameterisation) so that barycentric combinations of them are meaningful.
// Returns false if the corners are not in one or two adjacent tiles.
bool common_chart(const osd::Bfr::Parameterization& p, const float in[6], float chart[6], int& tile);
void chart_to_coord(const osd::Bfr::Parameterization& p, int tile, const float chart[2], float uv[2]);

// skin_blend.cpp: sparse blend of 4-joint skins, keeping the 4 largest weights, renormalised.
struct SkinAccumulator {
    std::array<uint16_t, 16> joint{};
    std::array<float, 16> weight{};
    int n = 0;
    void add(const uint16_t* joints, const float* weights, float w);
    void finish(uint16_t* joints_out, float* weights_out) const;
};

// Instance placements: the kernel's column-major 4×4 (furrow_kernel/affine.h).
using Mat4 = kernel::Mat4;
std::vector<Mat4> instance_matrices(const RateOptions& r);

// verify_rates.cpp: raises the wanted rates of faces whose measured chordal error exceeds the target.
void verify_error(std::vector<double>& wanted, const PreparedMesh& m, const RateOptions& r, const std::vector<Mat4>& inst,
                  const std::array<double, 3>& eye, double focal, double min_distance);

inline double length3(const std::array<double, 3>& a) { return std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]); }
inline double distance3(const std::array<double, 3>& a, const std::array<double, 3>& b) {
    return length3({a[0] - b[0], a[1] - b[1], a[2] - b[2]});
}

} // namespace furrow::tessellate_detail
