// Mesh validity report for one primitive (`furrow check`), and the sum over primitives.
//
// Definitions follow the usual ones of mesh repair (T. Ju, "Fixing geometric errors on polygonal models: a
// survey", J. Comput. Sci. Technol. 24(1), 2009; M. Attene et al., "Polygon mesh repairing: an application
// perspective", ACM Computing Surveys 45(2), 2013) and agree with the measurements of the shared corpus
// MANIFEST: everything topological is counted after welding by exact position, because that is the mesh a
// halfedge builder or an OpenSubdiv refiner sees once attribute seams are merged.
//
// Edge incidences come from sorting (edge key, corner) records, so every count is O(n log n) and
// independent of hashing. Non-manifold vertices are counted from fans built with a union-find over face
// corners (two faces around v belong to one fan when they share an edge incident to v), not from OpenMesh:
// a halfedge structure cannot represent exactly the configurations this has to count.
#include <furrow/mesh.h>

#include "self_intersections.h"

#include <furrow_kernel/disjoint_sets.h>
#include <furrow_kernel/vec3.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <limits>
#include <vector>

namespace furrow {
namespace {

constexpr double pi = std::numbers::pi;
using kernel::DisjointSets;
using V3 = kernel::Vec3;
using kernel::cross;
using kernel::dot;
using kernel::finite;
using kernel::norm;

size_t count_non_finite(const std::vector<float>& values) {
    size_t n = 0;
    for (float v : values) n += !std::isfinite(v);
    return n;
}

// One face's traversal of one edge, between two distinct welded vertices.
struct EdgeUse {
    uint64_t key;       // (min welded vertex << 32) | max welded vertex
    uint32_t corner_lo; // the face corner at the smaller welded vertex
    uint32_t corner_hi; // the face corner at the larger one
    bool forward;       // the face goes from the smaller to the larger vertex
};

// Non-finite values in every attribute, morph target and custom attribute.
size_t count_nan_values(const Primitive& prim) {
    size_t nan_values = count_non_finite(prim.positions) + count_non_finite(prim.normals) +
                        count_non_finite(prim.tangents) + count_non_finite(prim.uv0) + count_non_finite(prim.uv1) +
                        count_non_finite(prim.colors) + count_non_finite(prim.weights);
    for (const MorphTarget& t : prim.targets)
        nan_values += count_non_finite(t.position_deltas) + count_non_finite(t.normal_deltas) + count_non_finite(t.tangent_deltas);
    for (const CustomAttribute& a : prim.custom) nan_values += count_non_finite(a.values);
    return nan_values;
}

// Bounding box and diagonal of the finite positions, and the range of the finite UVs.
void measure_extent(CheckReport& r, const Primitive& prim) {
    const size_t n = prim.positions.size() / 3;
    auto point = [&](size_t v) { return kernel::point_at(prim.positions.data(), v); };
    {
        double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
        bool any = false;
        for (size_t v = 0; v < n; ++v) {
            V3 p = point(v);
            if (!finite(p)) continue;
            double c[3] = {p.x, p.y, p.z};
            for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], c[k]), hi[k] = std::max(hi[k], c[k]);
            any = true;
        }
        if (any) {
            for (int k = 0; k < 3; ++k) r.bbox_min[k] = lo[k], r.bbox_max[k] = hi[k];
            r.diagonal = norm(V3{hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
        }
    }
    r.has_uv = !prim.uv0.empty();
    {
        float lo[2] = {HUGE_VALF, HUGE_VALF}, hi[2] = {-HUGE_VALF, -HUGE_VALF};
        bool any = false;
        for (size_t i = 0; i + 2 <= prim.uv0.size(); i += 2) {
            if (!std::isfinite(prim.uv0[i]) || !std::isfinite(prim.uv0[i + 1])) continue;
            for (int k = 0; k < 2; ++k) lo[k] = std::min(lo[k], prim.uv0[i + k]), hi[k] = std::max(hi[k], prim.uv0[i + k]);
            any = true;
        }
        if (any) r.uv_min = {lo[0], lo[1]}, r.uv_max = {hi[0], hi[1]};
    }
}

// What the face pass gathers for the edge and fan passes.
struct FaceScan {
    DisjointSets corner_sets; // corners of one welded vertex joined into fans
    DisjointSets vertex_sets; // welded vertices joined into components
    std::vector<char> in_face; // welded vertex used by a valid face
    std::vector<EdgeUse> uses;
    std::vector<std::array<uint32_t, 3>> si_triangles; // welded, for the self-intersection test
    size_t proper_faces = 0;                           // valid and not degenerate
    FaceScan(size_t corners, size_t n) : corner_sets(corners), vertex_sets(n), in_face(n, 0) { uses.reserve(corners); }
};

// Faces: validity, geometry (zero-area, slivers), and the edge uses of every face with its corners in range.
void scan_faces(CheckReport& r, FaceScan& fs, const Primitive& prim, const std::vector<uint32_t>& remap, const CheckOptions& options) {
    const size_t n = prim.positions.size() / 3;
    const std::vector<uint32_t>& indices = prim.indices;
    auto point = [&](size_t v) { return kernel::point_at(prim.positions.data(), v); };
    DisjointSets& corner_sets = fs.corner_sets;
    DisjointSets& vertex_sets = fs.vertex_sets;
    std::vector<char>& in_face = fs.in_face;
    std::vector<EdgeUse>& uses = fs.uses;
    std::vector<std::array<uint32_t, 3>>& si_triangles = fs.si_triangles;
    size_t& proper_faces = fs.proper_faces;
    const bool polygons = !prim.face_sizes.empty();
    const double zero_area = options.zero_area_relative * r.diagonal * r.diagonal;
    const double sliver_angle = options.sliver_angle_degrees * pi / 180.0;

    std::vector<std::pair<uint32_t, uint32_t>> scratch;

    size_t first = 0;
    for (size_t f = 0; f < r.faces; ++f) {
        const size_t size = polygons ? prim.face_sizes[f] : 3;
        const size_t begin = first;
        first += size;
        const size_t available = begin < indices.size() ? std::min(size, indices.size() - begin) : 0;
        r.indices_out_of_range += size - available; // corners the index buffer does not hold
        if (size >= 3) r.triangles += size - 2;
        if (available < size) continue;
        bool in_range = true;
        for (size_t c = begin; c < begin + size; ++c) in_range = in_range && indices[c] < n;
        if (!in_range) continue;
        if (size < 3) { // a face that cannot span an area
            ++r.degenerate_faces;
            ++r.zero_area_faces;
            continue;
        }

        // A repeated welded vertex. Its corners are one face at that vertex, so join them for the fans.
        bool degenerate = false;
        scratch.clear();
        for (size_t c = begin; c < begin + size; ++c) scratch.push_back({remap[indices[c]], uint32_t(c)});
        std::sort(scratch.begin(), scratch.end());
        for (size_t i = 1; i < scratch.size(); ++i)
            if (scratch[i].first == scratch[i - 1].first) {
                degenerate = true;
                corner_sets.unite(scratch[i].second, scratch[i - 1].second);
            }

        // Topology includes degenerate faces: they are in the index buffer, and a viewer or a subdivision
        // refiner walks their edges too (this is what makes 73342.stl's doubled edges non-manifold).
        for (size_t i = 0; i < size; ++i) {
            const size_t c0 = begin + i, c1 = begin + (i + 1) % size;
            const uint32_t a = remap[indices[c0]], b = remap[indices[c1]];
            in_face[a] = 1;
            vertex_sets.unite(a, b);
            if (a == b) continue;
            const bool forward = a < b;
            const uint32_t lo = forward ? a : b, hi = forward ? b : a;
            uses.push_back({(uint64_t(lo) << 32) | hi, uint32_t(forward ? c0 : c1), uint32_t(forward ? c1 : c0),
                            forward});
        }

        if (degenerate) {
            ++r.degenerate_faces;
            ++r.zero_area_faces;
            continue;
        }
        ++proper_faces;

        // Geometry on the fan triangles, in double. A face with a non-finite corner has no geometry: it is
        // counted under nan_values, not as zero-area or sliver, and kept away from CGAL.
        bool finite_face = true;
        for (size_t c = begin; c < begin + size; ++c) finite_face = finite_face && finite(point(indices[c]));
        if (!finite_face) continue;
        const V3 p0 = point(indices[begin]);
        double area = 0;
        for (size_t i = 1; i + 1 < size; ++i) {
            const V3 p1 = point(indices[begin + i]), p2 = point(indices[begin + i + 1]);
            const double double_area = norm(cross(p1 - p0, p2 - p0));
            area += 0.5 * double_area;
            if (!(0.5 * double_area > zero_area)) continue; // angles of a zero-area triangle are noise
            const V3 p[3] = {p0, p1, p2};
            double min_angle = pi;
            for (int k = 0; k < 3; ++k) // atan2(|a×b|, a·b) stays accurate near 0° where acos does not
                min_angle = std::min(min_angle, std::atan2(double_area, dot(p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k])));
            if (min_angle < sliver_angle) ++r.slivers;
            if (options.self_intersections)
                si_triangles.push_back({remap[indices[begin]], remap[indices[begin + i]], remap[indices[begin + i + 1]]});
        }
        if (area <= zero_area) ++r.zero_area_faces;
    }
}

// Edges: boundary, inconsistent and non-manifold ones, valences; the corners across each edge join fans.
// Returns the index (into fs.uses) of the single use of every boundary edge.
std::vector<size_t> scan_edges(CheckReport& r, FaceScan& fs, std::vector<uint32_t>& valence, std::vector<char>& on_boundary) {
    std::vector<EdgeUse>& uses = fs.uses;
    DisjointSets& corner_sets = fs.corner_sets;
    std::sort(uses.begin(), uses.end(), [](const EdgeUse& a, const EdgeUse& b) {
        return a.key != b.key ? a.key < b.key : a.corner_lo < b.corner_lo;
    });
    std::vector<size_t> boundary; // index of the single use of each boundary edge
    for (size_t i = 0; i < uses.size();) {
        size_t j = i;
        while (j < uses.size() && uses[j].key == uses[i].key) ++j;
        const size_t k = j - i;
        const uint32_t lo = uint32_t(uses[i].key >> 32), hi = uint32_t(uses[i].key & 0xffffffffu);
        ++valence[lo];
        ++valence[hi];
        if (k == 1) {
            ++r.boundary_edges;
            on_boundary[lo] = on_boundary[hi] = 1;
            boundary.push_back(i);
        } else if (k == 2) {
            if (uses[i].forward == uses[i + 1].forward) ++r.inconsistent_edges;
        } else {
            ++r.non_manifold_edges;
        }
        for (size_t m = i + 1; m < j; ++m) {
            corner_sets.unite(uses[i].corner_lo, uses[m].corner_lo);
            corner_sets.unite(uses[i].corner_hi, uses[m].corner_hi);
        }
        i = j;
    }
    return boundary;
}

// Fans (a vertex with more than one is non-manifold), boundary loops (edges continue each other within a
// fan), components and interior valence-2 vertices.
void scan_fans(CheckReport& r, FaceScan& fs, const Primitive& prim, const std::vector<uint32_t>& remap, const std::vector<size_t>& boundary,
               const std::vector<uint32_t>& valence, const std::vector<char>& on_boundary) {
    const size_t n = prim.positions.size() / 3;
    const std::vector<uint32_t>& indices = prim.indices;
    const std::vector<EdgeUse>& uses = fs.uses;
    DisjointSets& corner_sets = fs.corner_sets;
    DisjointSets& vertex_sets = fs.vertex_sets;
    const std::vector<char>& in_face = fs.in_face;
    // Every set of corners is one fan at its welded vertex; count each set once, at its root.
    std::vector<uint32_t> fans(n, 0);
    {
        std::vector<char> seen(indices.size(), 0);
        for (const EdgeUse& u : uses)
            for (uint32_t c : {u.corner_lo, u.corner_hi}) {
                const uint32_t root = corner_sets.find(c);
                if (seen[root]) continue;
                seen[root] = 1;
                ++fans[remap[indices[c]]];
            }
    }
    for (size_t v = 0; v < n; ++v) r.non_manifold_vertices += fans[v] > 1;

    // Boundary edges meeting at a vertex continue each other when they lie in the same fan there; at a
    // bowtie vertex, the rims of the two fans stay separate loops, as they do in a halfedge structure.
    DisjointSets loop_sets(boundary.size());
    {
        std::vector<uint32_t> edge_at_fan(indices.size(), std::numeric_limits<uint32_t>::max());
        for (size_t b = 0; b < boundary.size(); ++b)
            for (uint32_t c : {uses[boundary[b]].corner_lo, uses[boundary[b]].corner_hi}) {
                uint32_t& slot = edge_at_fan[corner_sets.find(c)];
                if (slot == std::numeric_limits<uint32_t>::max()) slot = uint32_t(b);
                else loop_sets.unite(slot, uint32_t(b));
            }
    }
    for (size_t b = 0; b < boundary.size(); ++b) r.boundary_loops += loop_sets.find(uint32_t(b)) == b;

    for (size_t v = 0; v < n; ++v) {
        if (!in_face[v]) continue;
        if (vertex_sets.find(uint32_t(v)) == v) ++r.components;
        if (!on_boundary[v] && valence[v] == 2) ++r.valence2_interior_vertices;
    }
}

// Self-intersecting pairs among the proper faces' triangles (CGAL, exact predicates).
size_t count_self_intersecting(const Primitive& prim, std::vector<std::array<uint32_t, 3>>& si_triangles) {
    const size_t n = prim.positions.size() / 3;
    auto point = [&](size_t v) { return kernel::point_at(prim.positions.data(), v); };
    // Compact the welded vertices the triangles use; CGAL sees only what it has to test.
    std::vector<uint32_t> compact(n, std::numeric_limits<uint32_t>::max());
    std::vector<double> xyz;
    for (auto& t : si_triangles)
        for (uint32_t& v : t) {
            if (compact[v] == std::numeric_limits<uint32_t>::max()) {
                compact[v] = uint32_t(xyz.size() / 3);
                V3 p = point(v);
                xyz.insert(xyz.end(), {p.x, p.y, p.z});
            }
            v = compact[v];
        }
    return mesh_detail::count_self_intersections(xyz, si_triangles);
}

} // namespace

CheckReport check_primitive(const Primitive& prim, const CheckOptions& options) {
    CheckReport r;
    const size_t n = prim.positions.size() / 3;
    r.vertices = n;
    r.nan_values = count_nan_values(prim);
    measure_extent(r, prim);
    std::vector<uint32_t> remap(n);
    r.welded_vertices = weld_positions(remap.data(), prim.positions.data(), n);
    r.duplicate_vertices = n - r.welded_vertices;

    // Indices and references, for every mode. Non-indexed points reference all their vertices.
    const std::vector<uint32_t>& indices = prim.indices;
    std::vector<char> referenced(n, prim.mode == PrimitiveMode::points && indices.empty() ? 1 : 0);
    for (uint32_t i : indices) {
        if (i < n) referenced[i] = 1;
        else ++r.indices_out_of_range;
    }
    r.unreferenced_vertices = size_t(std::count(referenced.begin(), referenced.end(), 0));
    if (prim.mode != PrimitiveMode::triangles) return r;

    r.faces = prim.face_sizes.empty() ? indices.size() / 3 : prim.face_sizes.size();
    FaceScan fs(indices.size(), n);
    scan_faces(r, fs, prim, remap, options);
    std::vector<uint32_t> valence(n, 0);
    std::vector<char> on_boundary(n, 0);
    const std::vector<size_t> boundary = scan_edges(r, fs, valence, on_boundary);
    scan_fans(r, fs, prim, remap, boundary, valence, on_boundary);
    r.closed = r.boundary_edges == 0 && fs.proper_faces > 0;
    if (options.self_intersections) r.self_intersections = count_self_intersecting(prim, fs.si_triangles);
    return r;
}

CheckReport merge_reports(const std::vector<CheckReport>& reports) {
    CheckReport total;
    bool any_bbox = false, any_uv = false, any_si = false;
    total.closed = !reports.empty();
    total.self_intersections = 0;
    for (const CheckReport& r : reports) {
        total.vertices += r.vertices;
        total.faces += r.faces;
        total.triangles += r.triangles;
        total.welded_vertices += r.welded_vertices;
        total.components += r.components;
        total.boundary_edges += r.boundary_edges;
        total.boundary_loops += r.boundary_loops;
        total.non_manifold_edges += r.non_manifold_edges;
        total.non_manifold_vertices += r.non_manifold_vertices;
        total.degenerate_faces += r.degenerate_faces;
        total.zero_area_faces += r.zero_area_faces;
        total.slivers += r.slivers;
        total.duplicate_vertices += r.duplicate_vertices;
        total.unreferenced_vertices += r.unreferenced_vertices;
        total.nan_values += r.nan_values;
        total.indices_out_of_range += r.indices_out_of_range;
        total.inconsistent_edges += r.inconsistent_edges;
        total.valence2_interior_vertices += r.valence2_interior_vertices;
        if (r.self_intersections >= 0) {
            total.self_intersections += r.self_intersections;
            any_si = true;
        }
        total.closed = total.closed && r.closed;
        if (r.vertices > 0) { // a primitive without vertices has no box to unite
            for (int k = 0; k < 3; ++k) {
                total.bbox_min[k] = any_bbox ? std::min(total.bbox_min[k], r.bbox_min[k]) : r.bbox_min[k];
                total.bbox_max[k] = any_bbox ? std::max(total.bbox_max[k], r.bbox_max[k]) : r.bbox_max[k];
            }
            any_bbox = true;
        }
        if (r.has_uv) {
            for (int k = 0; k < 2; ++k) {
                total.uv_min[k] = any_uv ? std::min(total.uv_min[k], r.uv_min[k]) : r.uv_min[k];
                total.uv_max[k] = any_uv ? std::max(total.uv_max[k], r.uv_max[k]) : r.uv_max[k];
            }
            any_uv = true;
        }
    }
    total.has_uv = any_uv;
    if (!any_si) total.self_intersections = -1;
    double d2 = 0;
    for (int k = 0; k < 3; ++k) d2 += (total.bbox_max[k] - total.bbox_min[k]) * (total.bbox_max[k] - total.bbox_min[k]);
    total.diagonal = std::sqrt(d2);
    return total;
}

} // namespace furrow
